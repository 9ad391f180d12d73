"""The AMADEE-24 mission with its world model in PostGIS, and the server killed mid-mission.

`mrss supervise` runs a copy of projects/amadee whose `[worldmodel] url` names a
database of a private PostgreSQL server (tests/actors/worldmodel/pgcluster.py; skipped without
PostgreSQL 15 + PostGIS, failing instead when MRSS_REQUIRE_POSTGIS=1, as in CI). A legal
drive moves the rover; a drive across the salt marsh is refused with its rule and never
reaches the robot. The server is then SIGKILLed: a request meanwhile cannot be checked,
so it is dropped and the rover does not move. After the server restarts, every write
the world model acknowledged before the crash (the verdicts the reasoner acted on) is
there, and the mission goes on: the next legal drive moves the rover.
"""

from __future__ import annotations

import shutil
import urllib.error
from pathlib import Path
from typing import Any

import pytest

from mrss.actors.worldmodel.postgis import PostgisWorldStore
from mrss.api import distance_m
from mrss.api.testing import RunningProject
from tests.actors.worldmodel.pgcluster import started_cluster

PROJECT = Path(__file__).resolve().parents[3] / "projects" / "amadee"
SITE = (39.7705, 44.8000)
BEYOND_MARSH = (39.7725, 44.8010)
BACK = (39.7702, 44.7995)


def _on_postgis(target: Path, url: str) -> Path:
    """A copy of the project whose world model is the PostGIS database at `url`."""
    shutil.copytree(PROJECT, target, ignore=shutil.ignore_patterns("__pycache__"))
    toml = target / "project.toml"
    text = toml.read_text(encoding="utf-8")
    assert '\nseed = "world.json"' in text
    toml.write_text(text.replace('\nseed = "world.json"',
                                 f'\nseed = "world.json"\nurl = "{url}"'), encoding="utf-8")
    return target


def _position(system: RunningProject) -> tuple[float, float] | None:
    found = (system.world("rover1") or {}).get("position") or {}
    return (found["lat"], found["lon"]) if "lat" in found else None


def _succeeded(system: RunningProject, goal: str) -> list[Any]:
    return [s for s in system.statuses("rover1", "succeeded") if s.goal == goal]


def _world_up(system: RunningProject) -> bool:
    try:
        return system.world("habitat") is not None
    except OSError:
        return False


@pytest.mark.slow
def test_the_mission_on_postgis_refuses_illegal_drives_and_outlives_a_server_crash(
        tmp_path: Path) -> None:
    cluster = started_cluster()
    try:
        url = cluster.create_database("amadee")
        project = _on_postgis(tmp_path / "projects" / "amadee", url)
        with RunningProject(project, tmp_path / "run",
                            env={"MRSS_SIM_SPEEDUP": "20"}) as system:
            system.wait_ready()
            system.wait_for(lambda: _position(system), 30, "the rover's telemetry in PostGIS")

            system.publish("mrss/ui/drive", {"goal": "g1", "lat": SITE[0], "lon": SITE[1]})
            system.wait_for(lambda: _succeeded(system, "g1"), 60, "the legal drive")
            system.publish("mrss/ui/drive", {"goal": "g2", "lat": BEYOND_MARSH[0],
                                             "lon": BEYOND_MARSH[1]})
            system.wait_for(lambda: "g2: drive(rover1,g2,39.7725,44.801) refused by rule "
                            "no_go_path" in system.log(40000), 30, "the refusal")
            assert not [s for s in system.statuses("rover1") if s.goal == "g2"]
            acknowledged = {goal: (system.world(f"verdict_{goal}") or {}).get("attributes")
                            for goal in ("g1", "g2")}
            assert acknowledged["g2"] is not None and acknowledged["g2"]["rule"] == "no_go_path"
            here = _position(system)
            assert here is not None and distance_m(*here, *SITE) < 5.0

            cluster.kill()
            system.publish("mrss/ui/drive", {"goal": "g3", "lat": BACK[0], "lon": BACK[1]})
            system.wait_for(lambda: "goal g3 failed" in system.log(400_000), 30,
                            "the unchecked request dropped")
            assert not [s for s in system.statuses("rover1") if s.goal == "g3"]
            with pytest.raises(urllib.error.HTTPError) as down:
                system.world("habitat")
            assert down.value.code == 503   # the database, not the world model, is down

            cluster.restart_after_crash()
            stored = PostgisWorldStore(url)
            try:
                for goal, attributes in acknowledged.items():
                    found = stored.get(f"verdict_{goal}")
                    assert found is not None and found.attributes == attributes, goal
                assert stored.get("verdict_g3") is None   # never checked, never stored
            finally:
                stored.close()
            system.wait_for(lambda: _world_up(system), 30, "the world model reconnected")
            system.publish("mrss/ui/drive", {"goal": "g4", "lat": BACK[0], "lon": BACK[1]})
            system.wait_for(lambda: _succeeded(system, "g4"), 60, "the drive after the crash")
            assert (system.world("verdict_g4") or {}).get("attributes", {}).get("legal")
            system.wait_for(lambda: (p := _position(system)) is not None
                            and distance_m(*p, *BACK) < 5.0, 20, "the rover's new position")
            log = system.log(400_000)
            assert "telemetry not stored while a dependency is down" in log
            assert "telemetry stored again" in log
            assert "could not be forwarded" not in log
            assert "Traceback" not in log     # a database down is no bug: warnings only
    finally:
        cluster.stop()
