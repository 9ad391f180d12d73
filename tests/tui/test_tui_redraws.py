"""What the dashboard repaints: a growing log or table does not lay the whole screen out
again, a table changed by every drain is redrawn at most once a `table_every`, and the
dashboard's process quiets its garbage collector (`mrss bench tui` measures all three)."""

from __future__ import annotations

import math
import subprocess
import sys
import time
from pathlib import Path

from rich.text import Text
from textual.app import App, ComposeResult
from textual.screen import Screen

from mrss.bus import BusEndpoints
from mrss.messages import ActionStatus
from mrss.tui.app import MrssApp
from mrss.tui.widgets.actions_table import ActionsTable
from mrss.tui.widgets.log_pane import LogView
from tests.tui.tui_helpers import Peer, connected, row_text, run, until


class LogApp(App[None]):
    CSS = "LogView { height: 10; width: 60; }"

    def compose(self) -> ComposeResult:
        yield LogView()


def test_a_growing_log_lays_the_screen_out_only_when_a_scrollbar_appears() -> None:
    async def body() -> None:
        app = LogApp()
        async with app.run_test(size=(80, 20)) as pilot:
            view = app.query_one(LogView)
            await pilot.pause()  # the first layout
            layouts: list[Screen[None]] = []
            app.screen.screen_layout_refresh_signal.subscribe(app.screen, layouts.append)
            before = view.relayouts
            for i in range(40):  # each line in its own frame
                view.write(Text(f"line {i}"))
                await pilot.pause()
            assert layouts == [] and view.relayouts == before
            # it still follows: the last line is at the bottom, the thumb sized for 40 lines
            assert view.scroll_y == view.max_scroll_y == 40 - view.scrollable_content_region.height
            assert view.vertical_scrollbar.window_virtual_size == 40
            # a line wider than the view brings the horizontal scrollbar: that is a layout
            view.write(Text("x" * 200))
            # (the screen's layout signal may come a frame after the scrollbar shows)
            await until(pilot, lambda: view.show_horizontal_scrollbar and bool(layouts),
                        message="the scrollbar and the screen's layout")
            assert view.relayouts == before + 1
    run(body())


def test_a_table_changed_by_every_drain_is_redrawn_at_most_once_a_table_every(
        endpoints: BusEndpoints, peer: Peer) -> None:
    async def body() -> None:
        app = MrssApp(endpoints, project="demo", mind_every=0, tree_every=0, world_every=0,
                      min_refresh=0.05)
        async with app.run_test(size=(180, 50)) as pilot:
            await connected(pilot, peer)
            table = app.query_one(ActionsTable)
            uuid = "a" * 32
            draws, flushes, start = table.draws, app.flushes, time.monotonic()
            for step in range(1, 31):  # a new progress for each drain (0.05 s apart)
                peer.publish(ActionStatus(uuid=uuid, state="running", robot="ugv1",
                                          progress={"step": step, "steps": 30}))
                await pilot.pause(0.03)
            # the last progress is drawn all the same
            await until(pilot, lambda: row_text(table, uuid)[6].startswith("30/30")
                        if table.row_count else False, message="the last progress drawn")
            elapsed = time.monotonic() - start
            redraws = table.draws - draws
            assert app.flushes - flushes > redraws  # drains changed it more often than that
            # at most one per table_every, plus the first and one per second's tick
            assert redraws <= elapsed / app.table_every + math.ceil(elapsed) + 2
    run(body())


QUIET_GC_SCRIPT = """
import asyncio, gc, sys
from mrss.bus import BusEndpoints
from mrss.tui.app import MrssApp
from mrss.tui.gc_tuning import THRESHOLDS

async def main():
    app = MrssApp(BusEndpoints.ipc(sys.argv[1]), project="demo", mind_every=0,
                  tree_every=0, world_every=0, quiet_gc=True)
    async with app.run_test(size=(120, 40)) as pilot:
        for _ in range(200):
            if gc.get_freeze_count():
                break
            await pilot.pause(0.02)
        print(gc.get_threshold() == THRESHOLDS, gc.get_freeze_count() > 1000)

asyncio.run(main())
"""


def test_the_dashboard_process_quiets_its_garbage_collector_once_the_screen_is_up(
        tmp_path: Path) -> None:
    # in a process of its own: freezing the collector is process-wide
    done = subprocess.run([sys.executable, "-c", QUIET_GC_SCRIPT, str(tmp_path)],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["True", "True"]  # thresholds set, the widget tree frozen


def test_the_clock_moves_on_with_the_tick_and_a_pending_drain_takes_the_tick(
        endpoints: BusEndpoints, peer: Peer) -> None:
    """One frame a second: the header's clock has no timer of its own (Textual's did,
    a frame of its own each second), the tick repaints it; the second's timer leaves
    the tick to a drain that is pending, which runs it in its own frame."""
    from mrss.tui.widgets.ticked_header import TickedClock

    async def body() -> None:
        app = MrssApp(endpoints, project="demo", mind_every=0, tree_every=0, world_every=0)
        async with app.run_test(size=(180, 50)) as pilot:
            await connected(pilot, peer)
            clock = app.query_one(TickedClock)
            assert not clock._timers  # nothing repaints it on its own
            painted: list[int] = []
            clock.refresh = lambda *a, **k: painted.append(1) or clock  # type: ignore[method-assign]
            app.tick()
            assert painted == [1]
            ticked = app._ticked
            app.intake._drain_pending = True  # a drain is set: it will tick
            app._tick_due()
            assert app._ticked == ticked and painted == [1]
            app.intake._drain_pending = False
            app._tick_due()
            assert app._ticked > ticked and painted == [1, 1]
    run(body())
