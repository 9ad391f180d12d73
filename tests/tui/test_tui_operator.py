"""Operator keys and the percept line put the right messages on a real bus; bad input none."""

from __future__ import annotations

from pathlib import Path

from textual.widgets import Input

from mrss.bus import BusEndpoints
from mrss.messages import (
    ActionControl,
    ActionStatus,
    AllocationState,
    Command,
    FailureCause,
    Percept,
    RobotState,
    TaskAllocation,
)
from mrss.tui.app import MrssApp
from mrss.tui.confirm import ConfirmScreen
from mrss.tui.widgets.actions_table import ActionsTable
from mrss.tui.widgets.operator_bar import OperatorBar
from mrss.tui.widgets.robots_table import RobotsTable
from mrss.tui.widgets.supervision_table import SupervisionTable
from tests.tui.test_tui_panels import SIZE, make_app, tree_snapshot
from tests.tui.tui_helpers import Peer, confirmed, connected, has_row, row_text, run, until


def commands(peer: Peer) -> list[Command]:
    """The operator commands the TUI sent (not its periodic tree and mind requests)."""
    return [c for c in peer.received(Command)
            if c.command not in ("tree", "mind", "snapshot", "questions")]


def test_action_keys_send_cancel_suspend_resume_for_the_selected_action(
        endpoints: BusEndpoints, peer: Peer) -> None:
    async def body() -> None:
        app = make_app(endpoints)
        async with app.run_test(size=SIZE) as pilot:
            await connected(pilot, peer)
            table = app.query_one(ActionsTable)
            older, newer, done = "1" * 32, "2" * 32, "3" * 32
            for uuid in (done, older, newer):
                peer.publish(ActionStatus(uuid=uuid, state="running", robot="ugv1"))
            peer.publish(ActionStatus(uuid=done, state="succeeded", robot="ugv1"))
            await until(pilot, lambda: table.row_count == 3 and
                        row_text(table, done)[4] == "succeeded", message="three actions")
            table.focus()
            await pilot.press("down")  # from the newest to the older one
            assert table.selected_key == older
            # cancel asks first, naming the action; n (or Esc) sends nothing
            await pilot.press("c")
            screen = await until(pilot, lambda: isinstance(app.screen, ConfirmScreen)
                                 and app.screen, message="cancel confirmation")
            assert screen.question.startswith(f"Cancel action {older[:8]} (? on ugv1")
            await pilot.press("n")
            bar = app.query_one(OperatorBar)
            await until(pilot, lambda: "declined" in bar.status_text, message="declined")
            assert not isinstance(app.screen, ConfirmScreen)
            await pilot.press("c", "escape")
            await until(pilot, lambda: not isinstance(app.screen, ConfirmScreen),
                        message="escape declines")
            assert peer.received(ActionControl) == []
            # y sends it; suspend and resume need no confirmation
            await pilot.press("c", "y", "s", "r")
            await until(pilot, lambda: len(peer.received(ActionControl)) == 3,
                        message="three controls")
            assert peer.received(ActionControl) == [
                ActionControl(command=c, target=older, target_kind="action")
                for c in ("cancel", "suspend", "resume")]
            # a new action on top does not move the selection off the older one
            peer.publish(ActionStatus(uuid="4" * 32, state="pending"))
            await until(pilot, lambda: table.row_count == 4, message="fourth action")
            assert table.selected_key == older
            # a finished action is refused without sending anything
            await pilot.press("down")
            assert table.selected_key == done
            await pilot.press("c")
            await until(pilot, lambda: bar.status_error, message="refusal shown")
            assert "already succeeded" in bar.status_text
            assert not isinstance(app.screen, ConfirmScreen)
            await confirmed(pilot, "up", "c")
            await until(pilot, lambda: len(peer.received(ActionControl)) == 4,
                        message="fourth control")
            assert peer.received(ActionControl)[-1].target == older
    run(body())


def test_percept_line_sends_ground_literals_and_refuses_bad_ones_with_a_clear_error(
        endpoints: BusEndpoints, peer: Peer) -> None:
    async def body() -> None:
        app = make_app(endpoints)
        async with app.run_test(size=SIZE) as pilot:
            await connected(pilot, peer)
            bar = app.query_one(OperatorBar)
            await pilot.press("p")  # focus the percept line
            await pilot.press(*"fire(area1", "enter")
            await until(pilot, lambda: bar.status_error, message="syntax error shown")
            assert bar.status_text.startswith("percept not sent: not a literal: it ends too early")
            line = app.query_one("#percept", Input)
            assert line.value == "fire(area1"  # kept for fixing
            line.value = "fire(X)"
            await pilot.press("enter")
            await until(pilot, lambda: "ground" in bar.status_text, message="variable refused")
            line.value = "fire(area1, 3)"
            await pilot.press("enter")
            await until(pilot, lambda: peer.received(Percept), message="percept sent")
            assert line.value == ""
            line.value = "-fire(area1, 3)"
            await pilot.press("enter")
            await until(pilot, lambda: len(peer.received(Percept)) == 2,
                        message="removal sent")
            # only the two good lines were sent, in order; the bad ones sent nothing
            assert peer.received(Percept) == [Percept(literal="fire(area1, 3)"),
                                              Percept(literal="fire(area1, 3)", op="remove")]
            assert not bar.status_error and bar.status_text.startswith("sent percept remove")
    run(body())


def test_teleop_key_toggles_teleop_for_the_selected_robot(
        endpoints: BusEndpoints, peer: Peer) -> None:
    async def body() -> None:
        app = make_app(endpoints)
        async with app.run_test(size=SIZE) as pilot:
            await connected(pilot, peer)
            table = app.query_one(RobotsTable)
            peer.publish(RobotState(robot="ugv1", available=True, attributes={"teleop": False}))
            await until(pilot, lambda: has_row(table, "ugv1"), message="robot row")
            table.focus()
            await pilot.press("t")
            screen = await until(pilot, lambda: isinstance(app.screen, ConfirmScreen)
                                 and app.screen, message="teleop confirmation")
            assert screen.question == "Teleop ON for ugv1: take ugv1 over by hand?"
            await pilot.press("y")
            await until(pilot, lambda: commands(peer), message="teleop on")
            # the RCL answers with the robot's new state; the next t turns it off
            peer.publish(RobotState(robot="ugv1", available=True, attributes={"teleop": True}),
                         src="rcl")
            await until(pilot, lambda: row_text(table, "ugv1")[6] == "on", message="teleop shown")
            await confirmed(pilot, "t")
            await until(pilot, lambda: len(commands(peer)) == 2, message="teleop off")
            assert commands(peer) == [
                Command(command="teleop", target="ugv1", args={"on": True}),
                Command(command="teleop", target="ugv1", args={"on": False})]
    run(body())


def test_decommission_key_asks_naming_the_tasks_handed_on_then_toggles_back(
        endpoints: BusEndpoints, peer: Peer) -> None:
    async def body() -> None:
        app = make_app(endpoints)
        async with app.run_test(size=SIZE) as pilot:
            await connected(pilot, peer)
            table = app.query_one(RobotsTable)
            peer.publish(RobotState(robot="uav1", available=True))
            peer.publish(ActionStatus(uuid="t" * 32, state="running", robot="uav1",
                                      name="cover", goal="a1"))
            peer.publish(ActionStatus(uuid="n" * 32, state="running", robot="uav1",
                                      name="recharge", goal="b1"))
            peer.publish(TaskAllocation(uuid="t" * 32, state=AllocationState.AWARDED,
                                        robot="uav1", name="cover", goal="a1"))
            await until(pilot, lambda: has_row(table, "uav1") and len(app.actions.actions) == 2
                        and "t" * 32 in app.actions.tasks.tasks, message="robot, task, action")
            table.focus()
            await pilot.press("d")
            screen = await until(pilot, lambda: isinstance(app.screen, ConfirmScreen)
                                 and app.screen, message="decommission question")
            assert screen.question == "Decommission uav1: take it out of service?"
            assert screen.details[1:] == [
                "tasks handed to other robots (addressed to a role): cover a1 (tttttttt)",
                "actions that fail (addressed to it by name; the agent decides): recharge "
                "b1 (nnnnnnnn)"]
            await pilot.press("escape")
            assert commands(peer) == [] and "not sent (declined)" in \
                app.query_one(OperatorBar).status_text
            await confirmed(pilot, "d")
            await until(pilot, lambda: commands(peer), message="decommission sent")
            # the RCL answers with the robot's state: out of service; d puts it back
            peer.publish(RobotState(robot="uav1", available=False,
                                    reason="decommissioned by the operator",
                                    cause=FailureCause.DECOMMISSIONED), src="rcl")
            await until(pilot, lambda: row_text(table, "uav1")[1] == "decommissioned",
                        message="decommissioned shown")
            await pilot.press("d")
            screen = await until(pilot, lambda: isinstance(app.screen, ConfirmScreen)
                                 and app.screen, message="recommission question")
            assert screen.question == "Recommission uav1: back in service?"
            await pilot.press("y")
            await until(pilot, lambda: len(commands(peer)) == 2, message="recommission sent")
            assert commands(peer) == [Command(command="decommission", target="uav1"),
                                      Command(command="recommission", target="uav1")]
    run(body())


def test_fault_keys_need_a_second_press_and_reach_only_components(
        endpoints: BusEndpoints, peer: Peer) -> None:
    async def body() -> None:
        app = make_app(endpoints)
        async with app.run_test(size=SIZE) as pilot:
            await connected(pilot, peer)
            table = app.query_one(SupervisionTable)
            bar = app.query_one(OperatorBar)
            peer.publish(tree_snapshot())
            await until(pilot, lambda: has_row(table, "demo/announcer"), message="tree")
            table.focus()
            await pilot.press("down", "down")
            assert table.selected_key == "demo/announcer"
            await pilot.press("k")
            await until(pilot, lambda: "again" in bar.status_text, message="confirmation asked")
            await pilot.press("k")
            await until(pilot, lambda: commands(peer), message="fault sent")
            await pilot.press("h", "h")
            await until(pilot, lambda: len(commands(peer)) == 2, message="hang sent")
            assert commands(peer) == [
                Command(command="fault", target="announcer", args={"fault": "kill"}),
                Command(command="fault", target="announcer", args={"fault": "hang"})]
            # the root supervisor itself is not a component: refused, nothing sent
            await pilot.press("up", "up", "x", "x")
            await until(pilot, lambda: bar.status_error, message="refusal")
            assert "only the root supervisor's components" in bar.status_text
            assert len(commands(peer)) == 2
    run(body())


def test_a_burst_of_a_thousand_statuses_is_drawn_in_a_few_batches(
        endpoints: BusEndpoints, peer: Peer) -> None:
    async def body() -> None:
        app = make_app(endpoints)
        async with app.run_test(size=SIZE) as pilot:
            await connected(pilot, peer)
            table = app.query_one(ActionsTable)
            flushes, rebuilds = app.flushes, table.rebuilds
            for i in range(1000):
                peer.publish(ActionStatus(uuid=f"{i:032x}", state="running", robot="ugv1",
                                          progress={"i": i}))
            await until(pilot, lambda: len(app.actions.actions) == 1000 and
                        table.selected_key == f"{999:032x}", timeout=30,
                        message="1000 actions, the newest on top")
            # the table draws the newest MAX_ROWS and says so
            assert table.row_count == ActionsTable.MAX_ROWS < 1000
            assert table.border_subtitle == f"newest {ActionsTable.MAX_ROWS} of 1000"
            assert table.shown_keys()[-1] == f"{1000 - ActionsTable.MAX_ROWS:032x}"
            # batching: far fewer drains and table rebuilds than messages
            assert app.flushes - flushes < 100
            assert table.rebuilds - rebuilds < 100
            # and the app still answers keys at once
            table.focus()
            await confirmed(pilot, "c")
            await until(pilot, lambda: peer.received(ActionControl), message="control")
            assert peer.received(ActionControl)[0].target == f"{999:032x}"
    run(body())


def test_app_keeps_running_when_the_bus_has_no_proxy(tmp_path: Path) -> None:
    async def body() -> None:
        ep = BusEndpoints.ipc(tmp_path)
        app = MrssApp(ep, project="demo", mind_every=0.1, tree_every=0.1)
        async with app.run_test(size=SIZE) as pilot:
            await until(pilot, lambda: "waiting for the bus proxy" in str(app.sub_title),
                        message="waiting shown")
            await pilot.press("m", "f5")
            assert app.is_running
    run(body())
