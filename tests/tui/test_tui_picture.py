"""A picture that never lies: snapshots asked for on connect, F5 and proxy restarts; the
staleness banner; the final state kept; live progress; the log's follow/pause and
filter (pilot + a real proxy)."""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

from textual.widgets import Header, Input

from mrss.bus import BusEndpoints, ProxyThread, Subscriber
from mrss.messages import ActionQuery, ActionStatus, Command, Heartbeat, LogRecord, SupEvent
from mrss.tui.widgets.actions_table import ActionsTable
from mrss.tui.widgets.log_pane import LogPane, LogView
from tests.tui.test_tui_panels import SIZE, make_app, tree_snapshot
from tests.tui.tui_helpers import Peer, connected, has_row, row_text, run, until


def snapshots(peer: Peer) -> int:
    return sum(c.command == "snapshot" for c in peer.received(Command))


def test_snapshot_is_asked_for_on_connect_on_f5_and_after_a_proxy_restart() -> None:
    run_dir = Path(tempfile.mkdtemp(prefix="mrss-tui-"))
    endpoints = BusEndpoints.ipc(run_dir)
    proxy = ProxyThread(endpoints).start()
    peer = Peer(endpoints)

    async def body() -> None:
        nonlocal proxy
        app = make_app(endpoints)
        async with app.run_test(size=SIZE) as pilot:
            await connected(pilot, peer)
            await until(pilot, lambda: {"tree", "snapshot", "mind"} <= {
                c.command for c in peer.received(Command)}, message="the picture asked for")
            await until(pilot, lambda: app.snapshots_asked == 3, message="the retries")
            seen = snapshots(peer)
            await pilot.press("f5")
            await until(pilot, lambda: snapshots(peer) > seen, message="snapshot on F5")
            before = app.snapshots_asked
            proxy.stop()
            proxy = ProxyThread(endpoints).start()
            await until(pilot, lambda: app.snapshots_asked > before, timeout=20,
                        message="asked again after the proxy restart")
            seen = snapshots(peer)
            await until(pilot, lambda: snapshots(peer) > seen, timeout=20,
                        message="a snapshot request through the new proxy")

    try:
        run(body())
    finally:
        peer.close()
        proxy.stop()
        shutil.rmtree(run_dir, ignore_errors=True)


def test_f5_asks_the_rcl_for_actions_shown_open_and_one_that_ended_unseen_shows_its_end(
        endpoints: BusEndpoints, peer: Peer) -> None:
    queries: list[ActionQuery] = []
    rcl_side = Subscriber(endpoints, prefixes=["action.query"])
    rcl_side.start(lambda env: queries.append(env.body)
                   if isinstance(env.body, ActionQuery) and env.src == "tui" else None)

    async def body() -> None:
        app = make_app(endpoints)
        async with app.run_test(size=SIZE) as pilot:
            await connected(pilot, peer)
            assert rcl_side.wait_connected(10)
            table = app.query_one(ActionsTable)
            running, done = "d" * 32, "e" * 32
            peer.publish(ActionStatus(uuid=running, state="running", robot="ugv1"))
            peer.publish(ActionStatus(uuid=done, state="succeeded", robot="ugv1"))
            await until(pilot, lambda: table.row_count == 2, message="two actions")
            await pilot.press("f5")
            await until(pilot, lambda: queries, message="the status query")
            assert queries[-1] == ActionQuery(uuids=[running])  # only the ones shown open
            # the RCL answers from its journal: it was cancelled while we were away
            peer.publish(ActionStatus(uuid=running, state="cancelled", robot="ugv1",
                                      reason="cancelled by the operator", repeat=True))
            await until(pilot, lambda: row_text(table, running)[4] == "cancelled",
                        message="the end shown")

    try:
        run(body())
    finally:
        rcl_side.close()


def test_banner_turns_red_when_the_system_goes_quiet_and_keeps_a_give_up(
        endpoints: BusEndpoints, peer: Peer) -> None:
    async def body() -> None:
        app = make_app(endpoints, stale_after=0.5)
        async with app.run_test(size=SIZE) as pilot:
            await connected(pilot, peer)
            # the bus thread counts a message before the app's loop has handled it
            await until(pilot, lambda: app.liveness.last_heard is not None, timeout=30,
                        message="the probe heard by the app")
            header = app.query_one(Header)
            # (until the probe is drained the banner says nothing was heard yet)
            await until(pilot, lambda: app.banner_text().startswith("no heartbeat for "),
                        message="stale banner")
            await until(pilot, lambda: str(app.sub_title).startswith("no heartbeat for ")
                        and header.has_class("-stale"), message="header red, saying so")

            def beat_and_check() -> bool:
                peer.publish(Heartbeat(component="rcl", pid=1))
                return not header.has_class("-stale")

            await until(pilot, beat_and_check, message="fresh again on a heartbeat")
            peer.publish(SupEvent(event="give_up", child="rcl", supervisor="demo",
                                  reason="5 restarts in 10 s", detail={"stops": "system"}))
            await until(pilot, lambda: "gave up" in app.banner_text(), message="gave up shown")
            for _ in range(3):  # the final picture stays, whatever comes after
                peer.publish(Heartbeat(component="rcl", pid=1))
            await until(pilot, lambda: app.link.received > 10, message="more traffic")
            assert app.banner_text() == "demo gave up: rcl: 5 restarts in 10 s"
            assert header.has_class("-stale") and app.is_running
    run(body())


def test_a_system_whose_components_all_stopped_and_went_quiet_shows_stopped(
        endpoints: BusEndpoints, peer: Peer) -> None:
    async def body() -> None:
        app = make_app(endpoints, stale_after=0.5)
        async with app.run_test(size=SIZE) as pilot:
            await connected(pilot, peer)
            peer.publish(tree_snapshot())
            await until(pilot, lambda: app.supervision.root == "demo", message="the tree")
            # the root stops its children in reverse order; the proxy's own exit never
            # makes it onto the bus it was
            peer.publish(SupEvent(event="exit", child="announcer", supervisor="demo",
                                  reason="shutdown: stopped by supervisor"))
            await until(pilot, lambda: app.banner_text() ==
                        "system stopped: every component of demo stopped",
                        message="system stopped")
            peer.publish(SupEvent(event="start", child="bus", supervisor="demo", pid=7))
            await until(pilot, lambda: app.banner_text() == "", message="a new run")
    run(body())


def test_repeat_statuses_name_a_late_action_and_progress_moves_its_bar(
        endpoints: BusEndpoints, peer: Peer) -> None:
    async def body() -> None:
        app = make_app(endpoints)
        async with app.run_test(size=SIZE) as pilot:
            await connected(pilot, peer)
            table = app.query_one(ActionsTable)
            uuid = "c" * 32
            peer.publish(ActionStatus(uuid=uuid, state="running", robot="ugv1", repeat=True,
                                      name="patrol", goal="area1",
                                      progress={"leg": 3, "of": 12}), src="rcl")
            await until(pilot, lambda: has_row(table, uuid), message="the late action")
            assert row_text(table, uuid)[1:7] == ["patrol", "ugv1", "area1", "running", "",
                                                  "3/12 ██░░░░░░░░"]
            peer.publish(ActionStatus(uuid=uuid, state="running", robot="ugv1", repeat=True,
                                      progress={"leg": 12, "of": 12}), src="rcl")
            await until(pilot, lambda: row_text(table, uuid)[6] == "12/12 ██████████",
                        message="progress moved")
            assert row_text(table, uuid)[1] == "patrol"  # the name stays known
    run(body())


def test_log_follows_pauses_on_scroll_up_resumes_on_end_and_filters(
        endpoints: BusEndpoints, peer: Peer) -> None:
    async def body() -> None:
        app = make_app(endpoints)
        async with app.run_test(size=SIZE) as pilot:
            await connected(pilot, peer)
            pane = app.query_one(LogPane)
            view = app.query_one(LogView)
            for i in range(60):
                peer.publish(LogRecord(component="rcl", level="INFO", message=f"line {i}"))
            await until(pilot, lambda: "rcl: line 59" in " ".join(pane.lines_text()[-1:]),
                        message="60 lines")
            await until(pilot, lambda: view.max_scroll_y > 0 and
                        view.scroll_y == view.max_scroll_y, message="following the end")
            view.focus()
            await pilot.press("up", "up")
            assert not pane.following
            peer.publish(LogRecord(component="reasoner", level="WARNING", message="no robot"))
            peer.publish(LogRecord(component="rcl", level="ERROR", message="journal full"))
            await until(pilot, lambda: pane.missed == 2, message="two lines while paused")
            assert "paused, 2 new" in str(pane.border_subtitle)
            assert view.scroll_y < view.max_scroll_y  # it stayed where the operator was
            await pilot.press("end")
            assert pane.following
            await until(pilot, lambda: view.scroll_y == view.max_scroll_y, message="at the end")
            # / filters by level, component and words
            await pilot.press("slash")
            line = app.query_one("#log-filter", Input)
            assert line.has_focus
            line.value = "level:warn"
            await until(pilot, lambda: len(pane.shown_text()) == 2, message="warnings only")
            assert [t[9:] for t in pane.shown_text()] == ["WARN reasoner: no robot",
                                                          "ERRO rcl: journal full"]
            line.value = "@rcl line 5"
            await until(pilot, lambda: pane.filter.text == "@rcl line 5", message="refiltered")
            shown = [t[9:] for t in pane.shown_text()]  # words are not looked for in stamps
            assert shown == [f"INFO rcl: line {i}" for i in range(60) if "5" in str(i)]
            line.value = "comp:reason robot"
            await until(pilot, lambda: [t[9:] for t in pane.shown_text()] ==
                        ["WARN reasoner: no robot"], message="component and word")
            line.value = "level:loud"
            await until(pilot, lambda: "filter not applied" in str(pane.border_subtitle),
                        message="bad filter refused")
            assert pane.filter.text == "comp:reason robot"  # the previous filter stays
            assert "unknown level 'loud'" in str(pane.border_subtitle)
            line.value = ""
            await until(pilot, lambda: not pane.filter.active, message="filter cleared")
            await pilot.press("enter")
            assert view.has_focus and len(pane.shown_text()) == len(pane.lines_text())
    run(body())
