"""Safe exits and controls: q only detaches, X stops after a confirmation naming what
stops, and a read-only dashboard refuses every control (pilot + a real proxy)."""

from __future__ import annotations

from textual.widgets import Input

from mrss.bus import BusEndpoints
from mrss.messages import ActionControl, ActionStatus, Command, Percept, RobotState
from mrss.tui.confirm import ConfirmScreen
from mrss.tui.widgets.actions_table import ActionsTable
from mrss.tui.widgets.operator_bar import OperatorBar
from mrss.tui.widgets.robots_table import RobotsTable
from mrss.tui.widgets.supervision_table import SupervisionTable
from tests.tui.test_tui_operator import commands
from tests.tui.test_tui_panels import SIZE, make_app, tree_snapshot
from tests.tui.tui_helpers import Peer, confirmed, connected, has_row, run, until


def test_q_detaches_the_viewer_and_sends_nothing_to_the_system(
        endpoints: BusEndpoints, peer: Peer) -> None:
    async def body() -> None:
        app = make_app(endpoints)
        async with app.run_test(size=SIZE) as pilot:
            await connected(pilot, peer)
            await pilot.press("q")
            await until(pilot, lambda: not app.is_running, message="the app closed")
        assert commands(peer) == [] and peer.received(ActionControl) == []
    run(body())


def test_stop_key_asks_naming_components_robots_and_actions_and_sends_ctl_stop_on_yes(
        endpoints: BusEndpoints, peer: Peer) -> None:
    async def body() -> None:
        app = make_app(endpoints)
        async with app.run_test(size=SIZE) as pilot:
            await connected(pilot, peer)
            peer.publish(tree_snapshot())
            peer.publish(RobotState(robot="ugv1", available=True))
            peer.publish(ActionStatus(uuid="a" * 32, state="running", robot="ugv1",
                                      name="patrol"))
            await until(pilot, lambda: has_row(app.query_one(ActionsTable), "a" * 32)
                        and has_row(app.query_one(SupervisionTable), "demo/announcer")
                        and has_row(app.query_one(RobotsTable), "ugv1"), message="the picture")
            await pilot.press("X")
            screen = await until(pilot, lambda: isinstance(app.screen, ConfirmScreen)
                                 and app.screen, message="stop confirmation")
            assert screen.question == "Stop the whole system demo?"
            assert screen.details == ["components: bus, announcer", "robots: ugv1",
                                      "open actions: 1 (ended as the RCL stops)"]
            await pilot.press("n")  # declined: the system keeps running
            bar = app.query_one(OperatorBar)
            await until(pilot, lambda: "declined" in bar.status_text, message="declined")
            # any other key is a no too, and does not act underneath (q would detach)
            await pilot.press("X", "q")
            await until(pilot, lambda: not isinstance(app.screen, ConfirmScreen),
                        message="q declined")
            assert app.is_running and commands(peer) == []
            await confirmed(pilot, "X")
            await until(pilot, lambda: commands(peer), message="stop sent")
            assert commands(peer) == [Command(command="stop", target="demo")]
            assert app.is_running  # stopping the system does not close the dashboard
    run(body())


def test_readonly_dashboard_refuses_every_control_with_a_notice(
        endpoints: BusEndpoints, peer: Peer) -> None:
    async def body() -> None:
        app = make_app(endpoints, readonly=True)
        async with app.run_test(size=SIZE) as pilot:
            await connected(pilot, peer)
            assert app.query_one("#percept", Input).disabled
            peer.publish(tree_snapshot())
            peer.publish(RobotState(robot="ugv1", available=True))
            peer.publish(ActionStatus(uuid="a" * 32, state="running", robot="ugv1"))
            actions, robots = app.query_one(ActionsTable), app.query_one(RobotsTable)
            sup = app.query_one(SupervisionTable)
            await until(pilot, lambda: has_row(actions, "a" * 32) and has_row(robots, "ugv1")
                        and has_row(sup, "demo/announcer"), message="the picture")
            bar = app.query_one(OperatorBar)
            refusals = 0

            async def refused(*keys: str) -> None:
                nonlocal refusals
                await pilot.press(*keys)
                refusals += 1
                await until(pilot, lambda: bar.status_error and "read-only" in bar.status_text,
                            message=f"{keys} refused")
                assert not isinstance(app.screen, ConfirmScreen)
                bar.set_status("")

            actions.focus()
            for key in ("c", "s", "r"):
                await refused(key)
            robots.focus()
            await refused("t")
            await refused("d")  # decommission
            sup.focus()
            await pilot.press("down", "down")
            await refused("k")
            await refused("X")
            await refused("p")
            assert refusals == 8
            # the dashboard still asks for pictures (read-only requests) but sends no control
            assert commands(peer) == []
            assert peer.received(ActionControl) == [] and peer.received(Percept) == []
            await pilot.press("q")
            await until(pilot, lambda: not app.is_running, message="q still detaches")
    run(body())


def test_at_80x24_every_tab_key_focuses_its_panel_and_q_still_detaches_from_the_log(
        endpoints: BusEndpoints, peer: Peer) -> None:
    async def body() -> None:
        app = make_app(endpoints)
        async with app.run_test(size=(80, 24)) as pilot:
            await connected(pilot, peer)
            for key in "1234567":
                await pilot.press(key)
                focused = app.focused
                assert focused is not None and focused.display, key
                assert not isinstance(focused, Input), (key, focused)  # not a hidden line
            await pilot.press("q")  # on the log: a key, not the first letter of a filter
            await until(pilot, lambda: not app.is_running, message="the app closed")
    run(body())
