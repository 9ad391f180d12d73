"""`mrss recording report` on a real recording of the wildfire procedure: an operator's
area goal, the hotspot the world model sends the UGV to, the operator's teleop on the
way, a killed component; and the recording's world.geojson shows the area and hotspot."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
from contextlib import closing
from pathlib import Path

import pytest
from mcap.reader import make_reader

from mrss.api.testing import RunningProject
from mrss.recording.mission_figures import first_argument
from tests.commands.cli_bus import mrss, mrss_process

WILDFIRE = Path(__file__).resolve().parents[2] / "projects" / "wildfire"


def test_a_goals_name_is_its_percepts_first_argument() -> None:
    assert first_argument("hotspot_detected(hs1, -35.3, 149.1)") == "hs1"
    assert first_argument('area_goal_received("a1", 2)') == "a1"
    assert first_argument("hold_all") is None


def _operator(run_dir: Path, *command: str) -> None:
    """The project's operator console, as a user runs it (it waits for the answer)."""
    out = subprocess.run([sys.executable, str(WILDFIRE / "operator_console.py"),
                          "--run-dir", str(run_dir), *command],
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 0 and out.stdout.rstrip().endswith("-> accepted"), out


@pytest.mark.slow
def test_report_of_a_wildfire_recording(tmp_path: Path) -> None:
    out = tmp_path / "wildfire.mcap"
    run_dir = tmp_path / "run"
    # a loaded machine may take a minute to start the fork server and the proxy
    with closing(RunningProject(WILDFIRE, run_dir, env={"MRSS_SIM_SPEEDUP": "20"})
                 .start(timeout=90)) as system:
        with mrss_process("record", "--run-dir", str(run_dir), "--out", str(out),
                          "--project", str(WILDFIRE), "--timeout", "30") as rec:
            rec.wait_line("recording ", timeout=30)
            system.wait_ready()
            system.wait_for(lambda: (system.world("uav1") or {}).get("position")
                            and (system.world("ugv1") or {}).get("position"), 30,
                            "telemetry of both robots")
            _operator(run_dir, "area", "a1", "--center=-35.360567,149.165237",
                      "--radius", "100", "-p", "2")
            system.signal("events", signal.SIGKILL)  # a fault: restarted by the supervisor
            system.wait_for(lambda: system.incarnation("events") >= 2, 30,
                            "the events manager restarted")
            system.wait_for(lambda: system.statuses("uav1", "succeeded"), 60, "the cover")
            supply = system.wait_for(lambda: system.statuses("ugv1", "running"), 30,
                                     "the supply action to run")[0]
            _operator(run_dir, "teleop", "ugv1", "on")  # the operator takes the UGV over
            system.wait_for(lambda: [s for s in system.statuses("ugv1", "suspended")
                                     if s.uuid == supply.uuid], 20, "the supply suspended")
            _operator(run_dir, "teleop", "ugv1", "off")
            system.wait_for(lambda: [s for s in system.statuses("ugv1", "succeeded")
                                     if s.uuid == supply.uuid], 60, "the supply done")
            rec.proc.send_signal(signal.SIGINT)
            assert rec.finish() == 0, rec.stderr()
        assert system.interrupt() == 0

    report = mrss("recording", "report", str(out), "--format", "json")
    assert report.returncode == 0, report.stderr
    data = json.loads(report.stdout)
    assert data["project"] == "wildfire" and data["warnings"] == []
    goals = {g["goal"]: g for g in data["goals"] if g["reported"] is not None}
    assert set(goals) == {"a1", "hs1"}, data["goals"]
    area, hotspot = goals["a1"], goals["hs1"]
    assert area["robots"] == ["uav1"] and hotspot["robots"] == ["ugv1"]
    for goal in (area, hotspot):
        assert goal["outcome"] == "done"
        assert 0 <= goal["to_first_action"] < goal["to_done"]
    assert hotspot["reported"] > area["reported"]  # found while covering the area
    assert area["interventions"] == 0
    assert hotspot["interventions"] == 2  # teleop on, off: on its robot while it was open
    assert data["goals_reported"] == 2 and data["goals_done"] == 2
    assert data["goals_done_without_operator"] == 1
    assert data["share_done_without_operator"] == 0.5
    interventions = [i["what"] for i in data["interventions"]]
    assert len(interventions) == 2 and all(i.startswith("mrss/ui/teleop") for i in
                                           interventions), interventions
    assert data["interventions_per_hour"] == pytest.approx(2 / (data["span_s"] / 3600))
    actions = {(a["robot"], a["state"]): a["count"] for a in data["actions"]}
    assert actions[("uav1", "succeeded")] >= 1
    assert actions[("ugv1", "succeeded")] >= 3  # the supply, teleop on, teleop off
    assert data["restarts"].get("events") == 1
    assert {"event": "exit", "component": "events", "count": 1} in data["faults"]
    assert data["robot_losses"] == []

    text = mrss("recording", "report", str(out))
    assert text.returncode == 0, text.stderr
    assert "goals: 2 reported, 2 done, 1 done without an operator (50 % of the goals " \
           "reported)" in text.stdout
    assert "operator interventions: 2 (" in text.stdout

    # The map's channel: the operator's area and the hotspot the UAV found, latest state.
    with out.open("rb") as handle:
        shapes = [json.loads(json.loads(m.data)["geojson"]) for _, _, m in
                  make_reader(handle).iter_messages(topics=["world.geojson"])]
    assert shapes, "no world.geojson message"
    last = {f["id"]: f for f in shapes[-1]["features"]}
    assert last["a1"]["geometry"]["type"] == "Polygon"
    assert last["hs1"]["geometry"]["type"] == "Point"
    assert last["hs1"]["properties"]["kind"] == "hotspot"
    assert "uav1" not in last and "ugv1" not in last
