"""End-to-end procedure: the geofence, through `mrss supervise amadee` as real processes
(the UGV simulator, the broker, the data layer, the reasoner, the RCL).

The rover is driven into the salt marsh by hand (a `goto` straight to the simulator, as
someone at the rover's own controls would) and stops there. The data layer's geofence
finds it stopped inside and names its shortest legal way out; the agent drives it there
and a drive asked for meanwhile runs once it is out. The simulator's positions are
sampled all along: the exit is the nearest point of the marsh's outline that is not
next to another zone (a dune is laid right behind its nearest edge), plus the 1 m
margin, and the track never enters the dune. Boxed in by zones on every side, the rover
is told it is trapped, its drives are refused, and it does not move.

The way out outlives the data layer: the rover starts in the marsh, is told its way out,
and while it drives there (work waiting meanwhile) the data layer process is SIGKILLed
in the supervisor's tree. Its new incarnation takes back the percept its predecessor
told once the rover is out, and the waiting work runs.
"""

from __future__ import annotations

import json
import shutil
import signal
import threading
from pathlib import Path
from typing import Any

import pytest
from paho.mqtt import client as mqtt
from paho.mqtt.enums import CallbackAPIVersion
from shapely.geometry import LineString, Point, shape
from shapely.ops import nearest_points

from mrss.api import distance_m, project_broker_url
from mrss.api.testing import RunningProject

PROJECT = Path(__file__).resolve().parent.parent
INSIDE = (39.7712, 44.8012)   # in the marsh: its south edge 22.2 m away, east 25.7 m, west 60 m
SOUTH_EDGE, EAST_EDGE = 39.7710, 44.8015
SITE = (39.7715, 44.8025)     # east of the marsh, in the open: the work after
MARGIN_M = 1.0
TELEMETRY = "mrss/robots/rover1/telemetry"


def zone(zid: str, south: float, west: float, north: float, east: float) -> dict[str, Any]:
    ring = [[west, south], [east, south], [east, north], [west, north], [west, south]]
    return {"id": zid, "kind": "no_go", "attributes": {"what": "laid by the test"},
            "geometry": {"type": "Polygon", "coordinates": [ring]}}


#: Right behind the marsh's south edge, the nearest: the rover must leave by another.
DUNE = zone("dune", 39.7706, 44.8003, SOUTH_EDGE, 44.8017)
#: With the dune, the marsh boxed in on every side.
BOX = [DUNE, zone("north", 39.7720, 44.8003, 39.7724, 44.8017),
       zone("west", SOUTH_EDGE, 44.8003, 39.7720, 44.8005),
       zone("east", SOUTH_EDGE, EAST_EDGE, 39.7720, 44.8017)]


def project_with(tmp_path: Path, zones: list[dict[str, Any]], *,
                 start: tuple[float, float] | None = None, speedup: float = 4.0) -> Path:
    """AMADEE with `zones` added to its world, the simulator reporting at 10 Hz (from
    `start` instead of the habitat, at `speedup`)."""
    copy = tmp_path / "projects" / "amadee"
    shutil.copytree(PROJECT, copy, ignore=shutil.ignore_patterns("procedures", "__pycache__"))
    world = json.loads((copy / "world.json").read_text(encoding="utf-8"))
    (copy / "world.json").write_text(json.dumps(world + zones), encoding="utf-8")
    toml = (copy / "project.toml").read_text(encoding="utf-8")
    toml = toml.replace('speedup = 4.0', f'speedup = {speedup}\nrate = 10.0')
    if start is not None:
        toml = toml.replace('base = [39.7700, 44.8000]', f'base = [{start[0]}, {start[1]}]')
    (copy / "project.toml").write_text(toml, encoding="utf-8")
    return copy


class Track:
    """The simulator's own positions, every sample it publishes."""

    def __init__(self, broker_url: str) -> None:
        host, _, port = broker_url.rsplit("/", 1)[-1].rpartition(":")
        self.samples: list[tuple[float, float, float]] = []   # lat, lon, speed
        self.subscribed = threading.Event()
        self.client = mqtt.Client(CallbackAPIVersion.VERSION2, client_id="track")
        self.client.on_connect = lambda c, *_: c.subscribe(TELEMETRY)
        self.client.on_subscribe = lambda *_: self.subscribed.set()
        self.client.on_message = self._sample
        self.client.connect(host, int(port))
        self.client.loop_start()

    def _sample(self, _c: Any, _u: Any, message: Any) -> None:
        if message.topic != TELEMETRY:   # the broker also hands over the retained status
            return
        data = json.loads(message.payload)
        self.samples.append((float(data["lat"]), float(data["lon"]),
                             float(data.get("speed", 0.0))))

    def last(self) -> tuple[float, float, float] | None:
        return self.samples[-1] if self.samples else None

    def stopped_at(self, lat: float, lon: float, within_m: float = 0.5) -> bool:
        last = self.last()
        return last is not None and last[2] == 0.0 \
            and distance_m(last[0], last[1], lat, lon) <= within_m

    def close(self) -> None:
        self.client.disconnect()
        self.client.loop_stop()


def drive_in_by_hand(system: RunningProject, track: Track) -> int:
    """Drive the rover into the marsh by its own controls; the sample index it stopped at."""
    system.publish("mrss/robots/rover1/cmd", {"cmd": "goto", "id": "by-hand",
                                              "lat": INSIDE[0], "lon": INSIDE[1]})
    system.wait_for(lambda: track.stopped_at(*INSIDE), 60, "the rover stopped in the marsh")
    return len(track.samples) - 1


def started(tmp_path: Path, zones: list[dict[str, Any]],
            **options: Any) -> tuple[RunningProject, Track]:
    project = project_with(tmp_path, zones, **options)
    system = RunningProject(project, tmp_path / "run", env={"MRSS_SIM_SPEEDUP": ""}).start()
    system.wait_ready()
    system.wait_for(lambda: (system.world("rover1") or {}).get("position"), 20,
                    "the rover's telemetry in the world model")
    url = project_broker_url(project, tmp_path / "run")
    assert url is not None
    track = Track(url)
    system.wait_for(track.subscribed.is_set, 10, "the track's subscription")
    return system, track


@pytest.mark.slow
def test_the_rover_stopped_in_the_marsh_leaves_by_the_nearest_legal_exit_then_resumes(
        tmp_path: Path) -> None:
    system, track = started(tmp_path, [DUNE])
    try:
        stop = drive_in_by_hand(system, track)
        told = system.wait_for(lambda: system.perceived("geofence_exit(rover1,salt_marsh,"),
                               20, "the geofence's way out")
        lat, lon = (float(x) for x in told[0].rstrip(")").split(",")[2:])
        # the nearest point of the outline not next to the dune: the east edge, level with
        # the rover, 1 m beyond it (the south edge, nearer, has the dune behind it)
        nearest = (INSIDE[0], EAST_EDGE)
        expected = distance_m(*INSIDE, *nearest) + MARGIN_M
        assert distance_m(*INSIDE, lat, lon) == pytest.approx(expected, abs=0.3)
        assert distance_m(*nearest, lat, lon) == pytest.approx(MARGIN_M, abs=0.3)
        assert lon > EAST_EDGE

        system.wait_for(lambda: "is stopped inside no_go zone salt_marsh" in system.log(20000),
                        10, "the agent to take the way out")
        # the agent holds the way out: a drive asked for now waits for the rover to be out
        system.publish("mrss/ui/drive", {"goal": "g1", "lat": SITE[0], "lon": SITE[1]})

        system.wait_for(lambda: [s for s in system.statuses("rover1", "succeeded")
                                 if s.goal == "g1"], 60, "the work after the way out")
        escaped = [s for s in system.statuses("rover1", "succeeded") if s.goal == "geofence"]
        assert escaped, system.log()
        system.wait_for(lambda: track.stopped_at(*SITE, within_m=3.0), 10, "the rover at g1")

        path = track.samples[stop:]
        reached_exit = next(i for i, (a, o, _) in enumerate(path)
                            if distance_m(a, o, lat, lon) <= 1.0)
        reached_site = next(i for i, (a, o, _) in enumerate(path)
                            if distance_m(a, o, *SITE) <= 3.0)
        assert reached_exit < reached_site            # out first, then the work
        line = LineString([(o, a) for a, o, _ in path])
        assert not line.intersects(shape(DUNE["geometry"]))   # never into the dune
        way = sum(distance_m(a, o, a2, o2) for (a, o, _), (a2, o2, _) in
                  zip(path, path[1:reached_exit + 1], strict=False))
        assert way == pytest.approx(expected, abs=1.5), "the way out is not straight"
        print(f"\nway out: exit {distance_m(*INSIDE, lat, lon):.2f} m away (nearest legal "
              f"{expected:.2f} m), driven {way:.2f} m in {reached_exit} samples; g1 "
              + ("waited for it" if "goal g1 waits" in system.log(60000) else "came after"))
        verdict = system.world("verdict_g1")
        assert verdict is not None and verdict["attributes"]["legal"] is True
        assert not system.perceived("geofence_trapped(")
    finally:
        track.close()
        system.close()


@pytest.mark.slow
def test_a_rover_boxed_in_is_told_it_is_trapped_and_does_not_move(tmp_path: Path) -> None:
    system, track = started(tmp_path, BOX)
    try:
        stop = drive_in_by_hand(system, track)
        system.wait_for(lambda: system.perceived("geofence_trapped(rover1,salt_marsh)"), 20,
                        "the geofence's alert")
        system.wait_for(lambda: "cannot leave it: every way out of zone 'salt_marsh'"
                        in system.log(20000), 10, "the geofence's error in the log")
        system.wait_for(lambda: "every way out crosses another zone: it stays where it is"
                        in system.log(20000), 10, "the agent to know")
        system.publish("mrss/ui/drive", {"goal": "g2", "lat": SITE[0], "lon": SITE[1]})
        refused = system.wait_for(lambda: (system.world("verdict_g2") or {}).get("attributes"),
                                  30, "the verdict on g2")
        assert refused is not None
        assert refused["legal"] is False and refused["rule"] == "no_go_path", refused
        assert "every way out" in refused["detail"]
        assert not system.perceived("geofence_exit(")
        assert not system.statuses("rover1")          # nothing was asked of the rover
        # the next 3 s of the simulator's samples (10 a second): it stays where it stopped
        system.wait_for(lambda: len(track.samples) - stop > 30, 20, "30 more samples")
        moved = [s for s in track.samples[stop:] if distance_m(s[0], s[1], *INSIDE) > 0.5]
        assert not moved, moved[:5]
        assert not system.statuses("rover1")
    finally:
        track.close()
        system.close()


def marsh_outline(project: Path) -> Any:
    world = json.loads((project / "world.json").read_text(encoding="utf-8"))
    return shape(next(z for z in world if z.get("id") == "salt_marsh")["geometry"])


@pytest.mark.slow
def test_the_way_out_outlives_a_data_layer_killed_while_the_rover_leaves(
        tmp_path: Path) -> None:
    # 2x: the rover leaves the marsh (26.7 m) in about 4 s, time enough to kill the data
    # layer on the way; it starts stopped in the marsh (a restart that found it there)
    system, track = started(tmp_path, [DUNE], start=INSIDE, speedup=2.0)
    marsh = marsh_outline(PROJECT)
    try:
        told = system.wait_for(lambda: system.perceived("geofence_exit(rover1,salt_marsh,"),
                               30, "the geofence's way out")[0]
        [(_, _, sender, first)] = system.percept_events("geofence_exit(")
        system.wait_for(lambda: "leaving it by the shortest legal path" in system.log(20000),
                        20, "the agent to take the way out")
        # the agent holds the way out: a drive asked for now waits for the rover to be out
        system.publish("mrss/ui/drive", {"goal": "g1", "lat": SITE[0], "lon": SITE[1]})
        system.wait_for(lambda: "goal g1 waits until rover1 is out" in system.log(20000), 20,
                        "g1 to wait for the way out")
        system.wait_for(lambda: [s for s in system.statuses("rover1", "running")
                                 if s.goal == "geofence"], 30, "the drive out to run")

        killed = system.signal(sender, signal.SIGKILL)   # a real kill, in the tree
        at_kill = track.last()
        assert at_kill is not None
        assert marsh.contains(Point(at_kill[1], at_kill[0])), at_kill   # still inside
        assert [e for e in system.percept_events(told) if e[0] == "remove"] == []

        reborn = system.wait_for(lambda: system.component_pid(sender) not in (0, killed), 30,
                                 "a new data layer process")
        assert reborn
        removed = system.wait_for(lambda: [e for e in system.percept_events(told)
                                           if e[0] == "remove"], 60,
                                  "the way out taken back")
        assert [(op, src) for op, _, src, _ in removed] == [("remove", sender)]
        assert removed[0][3] > first, removed      # by the new incarnation
        assert "taking over what the previous incarnation told: 1 percept(s) standing" \
            in system.log(60000)
        out = track.last()
        assert out is not None and not marsh.covers(Point(out[1], out[0]))

        system.wait_for(lambda: [s for s in system.statuses("rover1", "succeeded")
                                 if s.goal == "g1"], 90, "the waiting work to run")
        assert "goal g1 resumes: rover1 is out of no_go zone salt_marsh" in system.log(60000)
        assert [s for s in system.statuses("rover1", "succeeded") if s.goal == "geofence"]
        system.wait_for(lambda: track.stopped_at(*SITE, within_m=3.0), 10, "the rover at g1")
        near = nearest_points(marsh.exterior, Point(at_kill[1], at_kill[0]))[0]
        edge = distance_m(at_kill[0], at_kill[1], near.y, near.x)
        print(f"\ndata layer {sender} killed (pid {killed}, incarnation {first}) with the rover "
              f"{edge:.1f} m from the marsh's outline; incarnation {removed[0][3]} took back "
              f"{told}; g1 then ran")
    finally:
        track.close()
        system.close()
