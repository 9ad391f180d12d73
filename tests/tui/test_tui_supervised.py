"""The dashboard `mrss supervise` opens on the system it started: q asks before stopping
it, X stops it, and a system that ends by itself leaves the final picture on screen.

The "system" is a real child process standing in for the root supervisor: it exits 0
on SIGINT (an ordered stop) and 3 when its stdin closes (the root gave up).
"""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from mrss.bus import BusEndpoints
from mrss.commands.supervise_tui import SupervisedApp
from mrss.tui.confirm import ConfirmScreen
from mrss.tui.widgets.operator_bar import OperatorBar
from tests.tui.test_tui_panels import SIZE
from tests.tui.tui_helpers import Peer, confirmed, connected, run, until

SYSTEM = """
import signal, sys
signal.signal(signal.SIGINT, lambda *_: sys.exit(0))
print("ready", flush=True)
sys.stdin.read()
sys.exit(3)
"""


@pytest.fixture()
def system() -> Iterator[subprocess.Popen[str]]:
    proc = subprocess.Popen([sys.executable, "-c", SYSTEM], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout is not None and proc.stdout.readline() == "ready\n"
        yield proc
    finally:
        if proc.poll() is None:
            proc.kill()
        proc.wait(timeout=10)
        for pipe in (proc.stdin, proc.stdout):
            if pipe is not None:
                pipe.close()


def make(endpoints: BusEndpoints, system: subprocess.Popen[str],
         log_path: Path | None = None) -> SupervisedApp:
    return SupervisedApp(endpoints, system, log_path,  # type: ignore[arg-type]
                         project="demo", mind_every=0, tree_every=0)


def test_q_asks_before_stopping_the_system_and_no_keeps_it_running(
        endpoints: BusEndpoints, peer: Peer, system: subprocess.Popen[str]) -> None:
    async def body() -> None:
        app = make(endpoints, system)
        async with app.run_test(size=SIZE) as pilot:
            await connected(pilot, peer)
            await pilot.press("q")
            screen = await until(pilot, lambda: isinstance(app.screen, ConfirmScreen)
                                 and app.screen, message="close confirmation")
            assert screen.question == "Close the dashboard and stop demo?"
            assert screen.details[0].startswith("components: ")
            await pilot.press("n")
            bar = app.query_one(OperatorBar)
            await until(pilot, lambda: "keeps running" in bar.status_text, message="declined")
            assert app.is_running and system.poll() is None and not app.stop_requested
            await confirmed(pilot, "q")
            await until(pilot, lambda: not app.is_running, message="closed")
        assert app.stop_requested  # run_with_dashboard then stops it with SIGINT
    run(body())


def test_stop_key_stops_the_system_and_the_dashboard_closes_when_it_has_ended(
        endpoints: BusEndpoints, peer: Peer, system: subprocess.Popen[str]) -> None:
    async def body() -> None:
        app = make(endpoints, system)
        async with app.run_test(size=SIZE) as pilot:
            await connected(pilot, peer)
            await pilot.press("X")
            await until(pilot, lambda: isinstance(app.screen, ConfirmScreen),
                        message="stop confirmation")
            await pilot.press("escape")
            await until(pilot, lambda: not isinstance(app.screen, ConfirmScreen),
                        message="declined")
            assert system.poll() is None
            await confirmed(pilot, "X")
            await until(pilot, lambda: not app.is_running, message="closed after the stop")
        assert system.wait(timeout=10) == 0  # the ordered stop (SIGINT)
    run(body())


def test_a_system_that_ends_by_itself_leaves_the_final_picture_and_its_reason(
        endpoints: BusEndpoints, peer: Peer, system: subprocess.Popen[str],
        tmp_path: Path) -> None:
    log_path = tmp_path / "mrss.log"
    log_path.write_text("... a component crashed\n"
                        "mrss supervise: demo: gave up: rcl: 6 restarts in 10 s\n")

    async def body() -> None:
        app = make(endpoints, system, log_path)
        async with app.run_test(size=SIZE) as pilot:
            await connected(pilot, peer)
            assert system.stdin is not None
            system.stdin.close()  # the root gives up: exit 3
            await until(pilot, lambda: app.banner_text().startswith("system stopped"),
                        message="the end shown")
            assert app.banner_text() == ("system stopped (exit 3): mrss supervise: demo: "
                                         "gave up: rcl: 6 restarts in 10 s")
            assert app.is_running  # the operator reads it, then closes: no question now
            await pilot.press("q")
            await until(pilot, lambda: not app.is_running, message="closed by q")
    run(body())
