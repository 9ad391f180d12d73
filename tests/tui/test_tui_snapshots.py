"""Snapshot tests of the main screens at 80 x 24 (compact: one panel, tabs), 120 x 35
and 200 x 50 (every panel), with pytest-textual-snapshot.

The picture is synthetic and frozen: messages with fixed times are applied directly,
the app's clock is fixed and the header shows no clock, the bus endpoints lead nowhere
(so the banner says "waiting for the bus proxy" whatever the machine), and times of
day are printed in UTC. `pytest tests/tui/test_tui_snapshots.py --snapshot-update`
rewrites the SVGs after a deliberate change; look at them before committing.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from typing import Any

import pytest

from mrss.bus import BusEndpoints
from mrss.config.operator import read_operator
from mrss.messages import (
    ActionRequest,
    ActionStatus,
    Envelope,
    Message,
    MindSnapshot,
    RobotData,
    RobotState,
    SupEvent,
)
from mrss.tui.app import MrssApp
from tests.tui.test_tui_mission_config import GOALS

T0 = 1_800_000_000.0  # the frozen "now" (2027-01-15 08:00 UTC)
NOWHERE = BusEndpoints("ipc:///nonexistent/mrss-snap/bus-pub.sock",
                       "ipc:///nonexistent/mrss-snap/bus-sub.sock")


@pytest.fixture(autouse=True)
def utc(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    monkeypatch.setenv("TZ", "UTC")
    time.tzset()
    yield
    monkeypatch.undo()
    time.tzset()


def _env(body: Message, ts: float, src: str = "rcl") -> Envelope:
    return Envelope(topic=body.topic(), id=f"m{ts}", ts=ts, src=src, inc=1, body=body)


def picture() -> list[Envelope]:
    """A mission in progress: a tree, two robots, three actions, the agent's goals."""
    def node(ident: str, pid: int, restarts: int = 0, reason: str = "") -> dict[str, Any]:
        return {"id": ident, "kind": "worker", "state": "running", "pid": pid,
                "incarnation": restarts + 1, "restarts": restarts, "uptime": 95.0,
                "last_reason": reason, "strategy": "", "children": []}
    tree = {"id": "wildfire", "kind": "supervisor", "state": "running", "pid": 4000,
            "incarnation": 0, "restarts": 0, "uptime": 0.0, "last_reason": "",
            "strategy": "one_for_one",
            "children": [node("bus", 4001), node("events", 4002), node("rcl", 4003),
                         node("reasoner", 4004, 1, "exit 1: InjectedFault: crash")]}
    msgs: list[tuple[Message, float, str]] = [
        (SupEvent(event="tree", child="wildfire", supervisor="wildfire",
                  detail={"tree": tree}), T0 - 5, "supervisor"),
        (RobotState(robot="uav1", available=True, attributes={"teleop": False}), T0 - 60, "rcl"),
        (RobotState(robot="ugv1", available=True, attributes={"teleop": False}), T0 - 60, "rcl"),
    ]
    for i in range(4):
        msgs.append((RobotData(robot="uav1", data={
            "type": "position", "lat": -35.3633 + 0.0004 * i, "lon": 149.1652 + 0.0002 * i,
            "relative_alt": 30.0, "heading": 20.0}), T0 - 8 + i, "rcl"))
    msgs += [
        (RobotData(robot="uav1", data={"type": "battery", "remaining": 74.0}), T0 - 2, "rcl"),
        (RobotData(robot="ugv1", data={"lat": -35.3635, "lon": 149.165, "battery": 18.0,
                                       "tank": {"level": 150.0, "capacity": 200.0}}),
         T0 - 3, "rcl"),
        (ActionRequest(uuid="a" * 32, name="cover", args=["uav1", "north"], robot="uav1",
                       goal="north", priority=2, literal="cover(uav1,north)"),
         T0 - 40, "reasoner"),
        (ActionStatus(uuid="a" * 32, state="running", robot="uav1"), T0 - 39, "rcl"),
        (ActionStatus(uuid="a" * 32, state="running", robot="uav1", repeat=True,
                      progress={"waypoint": 5, "waypoints": 12}), T0 - 1, "rcl"),
        (ActionRequest(uuid="b" * 32, name="cover", args=["uav1", "south"], robot="uav1",
                       goal="south", priority=1), T0 - 90, "reasoner"),
        (ActionStatus(uuid="b" * 32, state="suspended", robot="uav1",
                      reason="pre-empted by north"), T0 - 40, "rcl"),
        (ActionRequest(uuid="c" * 32, name="supply_water", args=["ugv1", "h1"], robot="ugv1",
                       goal="h1", priority=10), T0 - 200, "reasoner"),
        (ActionStatus(uuid="c" * 32, state="failed", robot="ugv1", cause="link_down",
                      reason="link lost"), T0 - 150, "rcl"),
        (MindSnapshot(agent="reasoner", beliefs=[
            "isuav(uav1)[source(self)]", "task(uav1,north,2)[source(self)]",
            "waiting(uav1,south,1)[source(self)]", "queued(uav1,east,1,cover)[source(self)]",
            "failed_goal(h1)[source(self)]"],
            intentions=[{"id": 3, "state": "waiting", "waiting_on": "cover(uav1,north)",
                         "stack": [{"trigger": "+!perform(uav1,north,2,cover)",
                                    "source": "agent.asl:160", "next": "cover(uav1,north)"}]}],
            events=[]), T0 - 1, "reasoner"),
    ]
    return [_env(body, ts, src) for body, ts, src in msgs]


def dashboard() -> MrssApp:
    return MrssApp(NOWHERE, project="wildfire", mind_every=0, tree_every=0, world_every=0,
                   operator_config=read_operator({"goals": GOALS}), clock=lambda: T0,
                   header_clock=False)


async def _fill(pilot: Any) -> None:
    app: Any = pilot.app
    app.apply(picture())
    await pilot.pause()


@pytest.mark.parametrize("size", [(80, 24), (120, 35), (200, 50)])
def test_dashboard_snapshot(snap_compare: Any, size: tuple[int, int]) -> None:
    assert snap_compare(dashboard(), terminal_size=size, run_before=_fill)


def test_compact_mission_tab_snapshot(snap_compare: Any) -> None:
    """80 x 24: key 5 shows the mission panel alone (the tab line names the others)."""
    assert snap_compare(dashboard(), terminal_size=(80, 24), run_before=_fill, press=["5"])
