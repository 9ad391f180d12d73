"""The dashboard's panels show what real bus messages say (Textual pilot + a real proxy)."""

from __future__ import annotations

import re

from mrss.bus import BusEndpoints
from mrss.messages import (
    ActionRequest,
    ActionStatus,
    GiveUpReason,
    GoalGaveUp,
    LogRecord,
    MindSnapshot,
    Rejections,
    RobotData,
    RobotState,
    SupEvent,
    encode,
    mark_replayed,
)
from mrss.tui.app import MrssApp
from mrss.tui.models.alerts import AlertKind
from mrss.tui.widgets.actions_table import ActionsTable
from mrss.tui.widgets.alerts_strip import AlertsStrip
from mrss.tui.widgets.log_pane import LogPane
from mrss.tui.widgets.mind_inspector import MindInspector
from mrss.tui.widgets.robots_table import RobotsTable
from mrss.tui.widgets.supervision_table import SupervisionTable
from tests.tui.tui_helpers import Peer, connected, has_row, row_text, run, until

SIZE = (180, 50)


def make_app(endpoints: BusEndpoints, **kw: float | bool) -> MrssApp:
    opts: dict[str, float | bool] = {"mind_every": 0.0, "tree_every": 0.0, **kw}
    return MrssApp(endpoints, project="demo", **opts)  # type: ignore[arg-type]


def tree_snapshot(announcer_state: str = "running", inc: int = 1, restarts: int = 0,
                  reason: str = "") -> SupEvent:
    child = {"id": "announcer", "kind": "worker", "state": announcer_state,
             "pid": 4242 if announcer_state == "running" else 0, "incarnation": inc,
             "restarts": restarts, "uptime": 75.0, "last_reason": reason, "strategy": "",
             "children": []}
    bus = {**child, "id": "bus", "pid": 4241, "incarnation": 1, "restarts": 0,
           "state": "running", "last_reason": ""}
    tree = {"id": "demo", "kind": "supervisor", "state": "running", "pid": 4240,
            "incarnation": 0, "restarts": 0, "uptime": 0.0, "last_reason": "",
            "strategy": "one_for_one", "children": [bus, child]}
    return SupEvent(event="tree", child="demo", supervisor="demo", detail={"tree": tree})


def test_supervision_table_shows_the_tree_snapshot_then_follows_sup_events(
        endpoints: BusEndpoints, peer: Peer) -> None:
    async def body() -> None:
        app = make_app(endpoints)
        async with app.run_test(size=SIZE) as pilot:
            await connected(pilot, peer)
            table = app.query_one(SupervisionTable)
            peer.publish(tree_snapshot())
            await until(pilot, lambda: has_row(table, "demo/announcer"), message="tree row")
            name, state, restarts, uptime, pid, inc, refused, reason = row_text(
                table, "demo/announcer")
            assert (name.strip(), state, pid, inc, restarts) == ("announcer", "running",
                                                                 "4242", "1", "0")
            # 75 s at the snapshot, and counting since (by how much is the machine's)
            minutes, seconds = re.fullmatch(r"(\d+)m(\d+)s", uptime.strip()).groups()  # type: ignore[union-attr]
            assert int(minutes) * 60 + int(seconds) >= 75, uptime
            assert (refused, reason) == ("", "")
            assert table.shown_keys() == ["demo", "demo/bus", "demo/announcer"]
            # the component is killed and restarted: exit, restart, start events
            peer.publish(SupEvent(event="exit", child="announcer", supervisor="demo",
                                  pid=4242, reason="killed: SIGKILL", detail={"inc": 1}))
            await until(pilot, lambda: row_text(table, "demo/announcer")[1] == "exited",
                        message="announcer exited")
            assert row_text(table, "demo/announcer")[7] == "killed: SIGKILL"
            assert row_text(table, "demo/announcer")[4] == ""  # no pid
            peer.publish(SupEvent(event="restart", child="announcer", supervisor="demo",
                                  count=1, reason="killed: SIGKILL"))
            peer.publish(SupEvent(event="start", child="announcer", supervisor="demo",
                                  pid=5151, detail={"inc": 2, "startup_ms": 3.0}))
            await until(pilot, lambda: [row_text(table, "demo/announcer")[i] for i in (1, 4, 5, 2)]
                        == ["running", "5151", "2", "1"], message="announcer restarted")
            # an actor supervisor inside the rcl component: nested under the component
            peer.publish(SupEvent(event="quarantine", child="uav1", supervisor="robots",
                                  reason="crashed: boom", detail={"robot": "uav1"}), src="rcl")
            await until(pilot, lambda: has_row(table, "demo/rcl/robots/uav1"),
                        message="actor row")
            assert row_text(table, "demo/rcl/robots/uav1")[:2] == ["      uav1", "quarantined"]
    run(body())


def test_robots_table_shows_availability_link_and_latest_telemetry(
        endpoints: BusEndpoints, peer: Peer) -> None:
    async def body() -> None:
        app = make_app(endpoints)
        async with app.run_test(size=SIZE) as pilot:
            await connected(pilot, peer)
            table = app.query_one(RobotsTable)
            peer.publish(RobotState(robot="ugv1", available=True, attributes={"teleop": False}))
            peer.publish(RobotData(robot="ugv1", data={"type": "position", "lat": 47.07,
                                                       "lon": 15.43, "heading": None}))
            peer.publish(RobotData(robot="ugv1", data={"type": "battery", "remaining": 81.0,
                                                       "voltage": None}))
            peer.publish(RobotData(robot="ugv1", data={"type": "tank", "level": 12.5,
                                                       "capacity": 20.0, "pumping": False}))
            peer.publish(RobotState(robot="uav1", available=False, link="down",
                                    reason="no heartbeat for 3.0 s"))
            peer.publish(RobotData(robot="uav1", data={"lat": 47.1, "lon": 15.4,
                                                       "relative_alt": 30.0, "battery": 55}))

            def shown() -> bool:
                return (has_row(table, "uav1") and has_row(table, "ugv1")
                        and row_text(table, "ugv1")[4] != "" and row_text(table, "uav1")[3] != "")

            await until(pilot, shown, message="both robots with telemetry")
            robot, available, link, battery, tank, goal, teleop, position, _, reason = \
                row_text(table, "ugv1")
            assert (available, link, teleop) == ("yes", "up", "off")
            assert (position, battery, tank) == ("47.07000, 15.43000", "81%", "12.5/20.0 L")
            assert row_text(table, "uav1")[1:3] == ["no", "down"]
            assert [row_text(table, "uav1")[i] for i in (7, 3)] == [
                "47.10000, 15.40000 alt 30.0", "55%"]  # position, battery
            assert goal == ""  # no goal patterns declared: no goals known
            assert row_text(table, "uav1")[9] == "no heartbeat for 3.0 s"
    run(body())


def test_a_replayed_robots_data_is_not_taken_for_the_robot_now(
        endpoints: BusEndpoints, peer: Peer) -> None:
    async def body() -> None:
        app = make_app(endpoints)
        async with app.run_test(size=SIZE) as pilot:
            await connected(pilot, peer)
            table = app.query_one(RobotsTable)
            topic, payload = encode(RobotData(robot="ugv1", data={"lat": 47.0, "lon": 15.0}),
                                    src="rcl", inc=1)
            peer.pub.send_frames([topic, mark_replayed(payload)])  # as `mrss replay` does
            peer.publish(RobotData(robot="uav1", data={"lat": 47.1, "lon": 15.4}))
            await until(pilot, lambda: has_row(table, "uav1"), message="the live robot")
            assert not has_row(table, "ugv1")
    run(body())


def test_actions_table_lists_actions_newest_first_with_state_reason_and_progress(
        endpoints: BusEndpoints, peer: Peer) -> None:
    async def body() -> None:
        app = make_app(endpoints)
        async with app.run_test(size=SIZE) as pilot:
            await connected(pilot, peer)
            table = app.query_one(ActionsTable)
            first, second = "a" * 32, "b" * 32
            peer.publish(ActionRequest(uuid=first, name="go_to", args=["area1"], robot="ugv1",
                                       goal="extinguish(area1)"))
            peer.publish(ActionStatus(uuid=first, state="running", robot="ugv1",
                                      progress={"waypoint": 2, "waypoints": 5, "eta": 3.5}))
            await until(pilot, lambda: has_row(table, first), message="first action")
            peer.publish(ActionStatus(uuid=second, state="failed", reason="link down",
                                      robot="uav1"))
            await until(pilot, lambda: has_row(table, second), message="second action")
            assert table.shown_keys() == [second, first]
            row = row_text(table, first)
            assert row[:7] == ["aaaaaaaa", "go_to", "ugv1", "extinguish(area1)", "running", "",
                               "2/5 ████░░░░░░ eta=3.5"]
            assert row[7].endswith("s")  # its age: seconds since the latest status
            assert row_text(table, second)[1:6] == ["?", "uav1", "", "failed", "link down"]
            peer.publish(ActionStatus(uuid=first, state="succeeded", robot="ugv1"))
            await until(pilot, lambda: row_text(table, first)[4] == "succeeded",
                        message="first action succeeded")
            assert table.shown_keys() == [second, first]
    run(body())


def test_mind_inspector_asks_for_snapshots_and_shows_beliefs_intentions_events(
        endpoints: BusEndpoints, peer: Peer) -> None:
    from mrss.messages import Command

    async def body() -> None:
        app = make_app(endpoints, mind_every=0.2)
        async with app.run_test(size=SIZE) as pilot:
            await connected(pilot, peer)
            await until(pilot, lambda: [c for c in peer.received(Command) if c.command == "mind"],
                        message="a periodic ctl.mind request")
            intention = {"id": 3, "state": "running", "suspended": False,
                         "waiting_on": "action 'go_to(area1)'",
                         "stack": [{"trigger": "+!extinguish(area1)", "plan": "...",
                                    "source": "agent.asl:12", "next": "go_to(area1)",
                                    "bindings": {"A": "area1"}}]}
            peer.publish(MindSnapshot(agent="reasoner", beliefs=["fire(area1)[source(percept)]"],
                                      intentions=[intention],
                                      events=["+fire(area2)"]),
                         src="reasoner")
            mind = app.query_one(MindInspector)
            await until(pilot, lambda: mind.snapshot is not None, message="mind snapshot shown")
            labels = [str(n.label) for n in _walk(mind.root)]
            assert "fire(area1)[source(percept)]" in labels
            assert any(label.startswith("#3 running") and "go_to(area1)" in label
                       for label in labels)
            assert any(label.startswith("+!extinguish(area1)") for label in labels)
            assert "bindings: A=area1" in labels
            assert "+fire(area2)" in labels
            app.auto_mind = False
            before = len(peer.received(Command))
            await pilot.press("m")
            await until(pilot, lambda: len(peer.received(Command)) > before,
                        message="ctl.mind on the m key")
            assert "mind" in [c.command for c in peer.received(Command)[before:]]
    run(body())


def _walk(node):  # type: ignore[no-untyped-def]
    for child in node.children:
        yield child
        yield from _walk(child)


def test_log_pane_shows_log_records_and_supervision_events_one_line_each(
        endpoints: BusEndpoints, peer: Peer) -> None:
    async def body() -> None:
        app = make_app(endpoints)
        async with app.run_test(size=SIZE) as pilot:
            await connected(pilot, peer)
            log = app.query_one(LogPane)
            peer.publish(LogRecord(component="announcer", level="INFO",
                                   message="started incarnation 2"))
            peer.publish(SupEvent(event="exit", child="announcer", supervisor="demo", pid=7,
                                  reason="killed: SIGKILL"))
            peer.publish(tree_snapshot())  # periodic traffic: not logged

            def lines() -> list[str]:
                return [line[9:] for line in log.lines_text()]  # without the time stamp

            await until(pilot, lambda: len(lines()) >= 2 and app.supervision.nodes,
                        message="two log lines")
            assert lines() == ["INFO announcer: started incarnation 2",
                               "sup.exit demo/announcer pid=7 reason='killed: SIGKILL'"]
    run(body())


def test_refusal_counters_show_per_component_and_as_one_alert(
        endpoints: BusEndpoints, peer: Peer) -> None:
    async def body() -> None:
        app = make_app(endpoints)
        async with app.run_test(size=SIZE) as pilot:
            await connected(pilot, peer)
            table, strip = app.query_one(SupervisionTable), app.query_one(AlertsStrip)
            peer.publish(tree_snapshot())
            await until(pilot, lambda: has_row(table, "demo/announcer"), message="tree")
            # what the announcer component publishes when it refused input (the source
            # of a report is the component's bus name, as every component's)
            peer.publish(Rejections(component="announcer", total=3, counts={
                "percept from tester: percept not ground": 2,
                "robot data from fz9: unknown robot": 1}), src="announcer")
            await until(pilot, lambda: row_text(table, "demo/announcer")[6] == "3",
                        message="the refused count")
            assert row_text(table, "demo/bus")[6] == ""
            await until(pilot, lambda: "refused input: announcer" in strip.plain,
                        message="the alert")
            assert "3 in all; most: percept from tester: percept not ground ×2" in strip.plain
            # more refusals: the count and the alert's text follow, still one alert
            peer.publish(Rejections(component="announcer", total=40, counts={
                "robot data from fz9: unknown robot": 38}), src="announcer")
            await until(pilot, lambda: row_text(table, "demo/announcer")[6] == "40",
                        message="the new count")
            await until(pilot, lambda: "40 in all; most: robot data from fz9" in strip.plain,
                        message="the alert's new text")
            assert [a.kind for a in app.alerts.history()] == [AlertKind.REFUSED]
            # a new incarnation starts counting again
            peer.publish(SupEvent(event="start", child="announcer", supervisor="demo",
                                  pid=5151, detail={"inc": 2}))
            await until(pilot, lambda: row_text(table, "demo/announcer")[5] == "2",
                        message="restarted")  # its incarnation
            assert row_text(table, "demo/announcer")[6] == ""
    run(body())


def test_a_goal_the_agent_gave_up_is_a_severe_alert_with_its_reason_and_cause(
        endpoints: BusEndpoints, peer: Peer) -> None:
    async def body() -> None:
        app = make_app(endpoints)
        async with app.run_test(size=SIZE) as pilot:
            await connected(pilot, peer)
            strip, log = app.query_one(AlertsStrip), app.query_one(LogPane)
            peer.publish(GoalGaveUp(agent="wildfire", goal="perform(ugv1,h1)",
                                    reason=GiveUpReason.BUDGET_EXHAUSTED, cause="link_down",
                                    message="given up by the program"), src="reasoner")
            await until(pilot, lambda: "goal given up: wildfire: perform(ugv1,h1)"
                        in strip.plain, message="the alert on the strip")
            assert "budget_exhausted (last cause: link_down)" in strip.plain
            await until(pilot, lambda: any("goal given up: wildfire: perform(ugv1,h1)" in line
                                           for line in log.lines_text()),
                        message="the alert in the log")
            [alert] = app.alerts.history()
            assert alert.kind is AlertKind.GOAL_GAVE_UP and alert.severe
            # the same goal given up again is the same alert, counted
            peer.publish(GoalGaveUp(agent="wildfire", goal="perform(ugv1,h1)",
                                    reason=GiveUpReason.PLAN_FAILED, cause="rejected"),
                         src="reasoner")
            await until(pilot, lambda: "plan_failed (last cause: rejected)" in strip.plain,
                        message="the recurrence")
            assert [a.count for a in app.alerts.history()] == [2]
    run(body())
