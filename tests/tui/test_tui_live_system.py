"""The dashboard against a live `mrss supervise busdemo`: tree over the bus, faults that bite."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import psutil
import pytest

from mrss.bus import Publisher
from mrss.messages import Command
from mrss.tui.app import MrssApp
from mrss.tui.discovery import find_endpoints
from mrss.tui.widgets.log_pane import LogPane
from mrss.tui.widgets.supervision_table import SupervisionTable
from tests.tui.tui_helpers import has_row, row_text, run, until

PROJECTS = Path(__file__).resolve().parent.parent / "projects"


@pytest.fixture()
def busdemo(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    """`mrss supervise busdemo --run-dir tmp_path` as a real process; its run dir."""
    monkeypatch.setenv("MRSS_PROJECTS", str(PROJECTS))
    proc = subprocess.Popen(
        [sys.executable, "-m", "mrss", "supervise", "busdemo", "--run-dir", str(tmp_path)],
        env=os.environ.copy(), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        yield tmp_path
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=30)
        assert proc.returncode == 0, err
    finally:
        if proc.poll() is None:
            for child in psutil.Process(proc.pid).children(recursive=True):
                child.kill()
            proc.kill()
            proc.communicate(timeout=10)


def test_dashboard_shows_the_live_tree_and_its_fault_keys_kill_and_hang_a_component(
        busdemo: Path) -> None:
    endpoints, name = find_endpoints("busdemo", run_dir=busdemo)
    assert name == "busdemo"

    async def body() -> None:
        app = MrssApp(endpoints, project=name, mind_every=0, tree_every=0.3)
        async with app.run_test(size=(180, 50)) as pilot:
            table = app.query_one(SupervisionTable)
            row = "busdemo/announcer"

            def announcer(inc: int) -> list[str] | None:
                if not has_row(table, row):
                    return None
                cells = row_text(table, row)
                return cells if cells[1] == "running" and cells[3] == str(inc) else None

            await until(pilot, lambda: announcer(1), timeout=30, message="announcer running")
            assert [k.value for k in table.rows] == ["busdemo", "busdemo/bus", row]
            table.focus()
            await pilot.press("down", "down")
            assert table.selected_key == row
            await pilot.press("k", "k")
            cells = await until(pilot, lambda: announcer(2), timeout=30,
                                message="announcer killed and restarted")
            assert cells[4] == "1" and "SIGKILL" in cells[6]
            log = app.query_one(LogPane)
            await until(pilot, lambda: any("fault kill injected into announcer" in line
                                           for line in log.lines_text()), message="fault logged")
            await pilot.press("h", "h")
            cells = await until(pilot, lambda: announcer(3), timeout=30,
                                message="hung announcer found and restarted")
            assert cells[4] == "2" and "hung" in cells[6]
            # a bad fault request from elsewhere on the bus is refused, and said so
            with Publisher(endpoints, src="operator2") as other:
                assert other.wait_connected(10)
                other.publish(Command(command="fault", target="announcer",
                                      args={"fault": "explode"}))
                other.publish(Command(command="fault", target="nobody",
                                      args={"fault": "kill"}))
            await until(pilot, lambda: sum("refused" in line for line in log.lines_text()) == 2,
                        message="two refusals logged")
            refusals = [line for line in log.lines_text() if "refused" in line]
            assert "unknown fault 'explode'" in refusals[0]
            assert "has no child 'nobody'" in refusals[1]
            assert announcer(3) is not None
    run(body())
