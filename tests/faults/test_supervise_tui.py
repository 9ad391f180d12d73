"""`mrss supervise` in a terminal opens the dashboard; quitting it stops the system.

The terminal is a real pseudo-terminal: `mrss supervise busdemo` runs as the session
leader on it (it is its controlling terminal, so Ctrl-C is a signal as in a shell), a
thread reads what the dashboard draws, and keys are written to the master side.
"""

from __future__ import annotations

import fcntl
import os
import pty
import re
import signal
import struct
import subprocess
import sys
import termios
import threading
from collections.abc import Iterator
from pathlib import Path

import psutil
import pytest

from mrss.testing import wait_until

PROJECTS = Path(__file__).resolve().parent.parent / "projects"
LOG_PROJECTS = PROJECTS.parent / "supervision" / "projects"  # logsdemo: chatty talks
# Make the terminal the new session's controlling terminal, then exec the command.
TAKE_TTY = ("import os, sys; os.close(os.open(os.ttyname(0), os.O_RDWR)); "
            "os.execv(sys.argv[1], sys.argv[1:])")


class Terminal:
    """A process on a pseudo-terminal, with everything it wrote kept."""

    def __init__(self, argv: list[str], env: dict[str, str], rows: int = 40,
                 cols: int = 140) -> None:
        # The size is the terminal's: COLUMNS/LINES left in the environment (pytest-xdist's
        # workers have 80x24 there) would override it for the dashboard.
        env = {k: v for k, v in env.items() if k not in ("COLUMNS", "LINES")}
        self.master, slave = pty.openpty()
        fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", rows, cols, 0, 0))
        try:
            self.proc = subprocess.Popen([sys.executable, "-c", TAKE_TTY, *argv], env=env,
                                         stdin=slave, stdout=slave, stderr=slave,
                                         start_new_session=True)
        finally:
            os.close(slave)
        self._out = bytearray()
        self._lock = threading.Lock()
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        while True:
            try:
                data = os.read(self.master, 65536)
            except OSError:  # EIO: every process holding the terminal is gone
                return
            if not data:
                return
            with self._lock:
                self._out += data

    @property
    def output(self) -> bytes:
        with self._lock:
            return bytes(self._out)

    def press(self, keys: bytes) -> None:
        os.write(self.master, keys)

    def hang_up(self) -> None:
        """Close the terminal, as closing its window does: the kernel sends SIGHUP."""
        if self.master >= 0:
            os.close(self.master)
            self.master = -1

    def close(self) -> None:
        if self.proc.poll() is None:
            for child in psutil.Process(self.proc.pid).children(recursive=True):
                child.kill()
            self.proc.kill()
        self.proc.wait(timeout=10)
        self.hang_up()
        self._reader.join(timeout=5)


def supervise_in_terminal(project: str, run_dir: Path, *extra: str,
                          projects: Path = PROJECTS) -> Terminal:
    env = {**os.environ, "MRSS_PROJECTS": str(projects), "TERM": "xterm-256color"}
    return Terminal([sys.executable, "-m", "mrss", "supervise", project, "--run-dir",
                     str(run_dir), *extra], env)


@pytest.fixture()
def terminal(tmp_path: Path) -> Iterator[Terminal]:
    term = supervise_in_terminal("busdemo", tmp_path)
    try:
        yield term
    finally:
        term.close()


def _system_up(term: Terminal, run_dir: Path) -> list[psutil.Process]:
    """Wait for the dashboard and the system; the processes of the run."""
    log = run_dir / "mrss.log"
    wait_until(lambda: log.exists() and "start announcer" in log.read_text(), timeout=30,
               message="busdemo started (mrss.log)")
    wait_until(lambda: b"Supervision" in term.output and b"announcer" in term.output,
               timeout=30, message="the dashboard shows the supervision tree")
    # the system's root, the fork server, the proxy and the announcer
    def run_processes() -> list[psutil.Process]:
        found = psutil.Process(term.proc.pid).children(recursive=True)
        return found if len(found) >= 4 else []

    return wait_until(run_processes, timeout=20, message="the processes of busdemo")


def _gone(procs: list[psutil.Process]) -> bool:
    return all(not p.is_running() or p.status() == psutil.STATUS_ZOMBIE for p in procs)


@pytest.mark.slow
def test_q_in_the_dashboard_stops_the_system_cleanly(terminal: Terminal,
                                                     tmp_path: Path) -> None:
    procs = _system_up(terminal, tmp_path)
    # the log lines go to the file, not over the dashboard
    assert not re.search(rb"busdemo\[\d+\] INFO", terminal.output)
    terminal.press(b"q")  # asks first: closing this dashboard stops the system
    wait_until(lambda: b"Close the dashboard and stop busdemo?" in terminal.output,
               timeout=30, message="the question")
    terminal.press(b"y")
    assert terminal.proc.wait(timeout=30) == 0
    wait_until(lambda: _gone(procs), timeout=10, message="no process of the run left")
    log = (tmp_path / "mrss.log").read_text()
    assert "dashboard closed: stopping busdemo" in log
    assert "exit announcer" in log and "all components stopped" in log
    assert re.search(r"busdemo\[\d+\] INFO supervising busdemo", log)
    assert b"busdemo stopped (exit 0)" in terminal.output


@pytest.mark.slow
def test_ctrl_c_in_the_dashboard_stops_the_system_like_without_it(
        terminal: Terminal, tmp_path: Path) -> None:
    procs = _system_up(terminal, tmp_path)
    terminal.press(b"\x03")  # the terminal makes it SIGINT, passed on to the system
    assert terminal.proc.wait(timeout=30) == 0
    wait_until(lambda: _gone(procs), timeout=10, message="no process of the run left")
    log = (tmp_path / "mrss.log").read_text()
    assert "stopping every child in reverse order" in log
    assert "all components stopped" in log
    assert "dashboard closed" not in log  # the system ended first, then the dashboard


@pytest.mark.slow
def test_closing_the_terminal_stops_the_system_and_the_dashboard_ends_too(
        terminal: Terminal, tmp_path: Path) -> None:
    procs = _system_up(terminal, tmp_path)
    terminal.hang_up()  # nothing left to draw on: nothing of the run may linger
    wait_until(lambda: terminal.proc.poll() is not None, timeout=30,
               message="the dashboard's process ended after its terminal closed")
    wait_until(lambda: _gone(procs), timeout=10, message="no process of the run left")
    log = (tmp_path / "mrss.log").read_text()
    assert "all components stopped" in log  # stopped in order, not killed


@pytest.mark.slow
def test_the_log_pane_shows_the_records_the_log_file_has(tmp_path: Path) -> None:
    term = supervise_in_terminal("logsdemo", tmp_path, projects=LOG_PROJECTS)
    try:
        shown = wait_until(lambda: re.search(rb"chatty says hello (\d+)", term.output),
                           timeout=30, message="a component's warning in the log pane")
        assert shown is not None
        number = shown.group(1).decode()
        assert re.search(rf"chatty\[\d+\] WARNING chatty says hello {number}$",
                         (tmp_path / "mrss.log").read_text(), re.M)
        assert b"via the bus logger" not in term.output  # file only, as on the bus
        term.press(b"q")
        wait_until(lambda: b"Close the dashboard" in term.output, timeout=30,
                   message="the question")
        term.press(b"y")
        assert term.proc.wait(timeout=30) == 0
    finally:
        term.close()


@pytest.mark.slow
def test_a_system_that_gives_up_keeps_the_final_picture_until_q_and_says_why(
        tmp_path: Path) -> None:
    term = supervise_in_terminal("crashloop", tmp_path)
    try:
        wait_until(lambda: b"system stopped (exit 1)" in term.output, timeout=60,
                   message="the red banner on the final picture")
        assert term.proc.poll() is None  # the dashboard stays for the operator to read
        term.press(b"q")  # no question: the system has ended
        assert term.proc.wait(timeout=30) == 1
        wait_until(lambda: b"more than 2 restarts of flaky in 30s" in term.output, timeout=10,
                   message="the root's last words on the terminal")
        assert b"mrss supervise: crashloop: gave up: child 'flaky' failed" in term.output
        assert b"crashloop stopped (exit 1)" in term.output
        assert "gave up" in (tmp_path / "mrss.log").read_text()
    finally:
        term.close()


def test_no_tui_keeps_plain_logs_on_stderr_even_in_a_terminal(tmp_path: Path) -> None:
    term = supervise_in_terminal("busdemo", tmp_path, "--no-tui")
    try:
        wait_until(lambda: b"start announcer" in term.output, timeout=30,
                   message="plain log lines on the terminal")
        assert b"Supervision" not in term.output
        term.proc.send_signal(signal.SIGTERM)
        assert term.proc.wait(timeout=30) == 0
        assert "all components stopped" in (tmp_path / "mrss.log").read_text()
    finally:
        term.close()


@pytest.mark.slow
def test_mrss_tui_readonly_in_a_terminal_refuses_controls_and_q_only_detaches(
        tmp_path: Path) -> None:
    """`mrss supervise busdemo --no-tui` runs; `mrss tui --readonly` on another terminal:
    X is refused with the notice, q detaches and the system runs on."""
    system = supervise_in_terminal("busdemo", tmp_path, "--no-tui")
    env = {**os.environ, "MRSS_PROJECTS": str(PROJECTS), "TERM": "xterm-256color"}
    viewer = Terminal([sys.executable, "-m", "mrss", "tui", "busdemo", "--run-dir",
                       str(tmp_path), "--readonly"], env)
    try:
        wait_until(lambda: b"announcer" in viewer.output and b"read-only" in viewer.output,
                   timeout=30, message="the read-only dashboard shows the tree")
        viewer.press(b"X")
        wait_until(lambda: b"no controls" in viewer.output, timeout=10,
                   message="the refusal notice")
        viewer.press(b"q")
        assert viewer.proc.wait(timeout=30) == 0
        wait_until(lambda: b"detached from busdemo; it keeps running" in viewer.output,
                   timeout=10, message="the parting words")
        assert system.proc.poll() is None  # still running
        system.proc.send_signal(signal.SIGTERM)
        assert system.proc.wait(timeout=30) == 0
        log = (tmp_path / "mrss.log").read_text()
        assert "stopping busdemo: asked by" not in log  # nobody asked the root to stop
    finally:
        viewer.close()
        system.close()
