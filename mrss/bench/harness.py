"""A throwaway project run by `mrss supervise` for a benchmark, with the bench's bus client."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import tempfile
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

from mrss.bus import BusEndpoints, Publisher, Subscriber
from mrss.interpreter import python_module
from mrss.messages import Envelope


class SupervisedProject:
    """Writes `files` into a temporary `projects/<name>/`, runs `mrss supervise` on it as
    a real process (log in `supervise.log`), and connects a subscriber and a publisher to
    its bus. `close()` stops the system and removes everything. With `nice` the root
    supervisor runs at that nice value (as `nice -n N mrss supervise` would; its fork
    server and components inherit it unless their table sets `nice`), with `realtime` at
    that SCHED_RR priority (as `chrt -r N mrss supervise`)."""

    def __init__(self, name: str, files: Mapping[str, str], *, prefixes: Sequence[str],
                 on_message: Callable[[Envelope], None], tmp_prefix: str,
                 nice: int | None = None, realtime: int | None = None,
                 direct: bool = False) -> None:
        self.tmp = Path(tempfile.mkdtemp(prefix=tmp_prefix))
        project = self.tmp / "projects" / name
        project.mkdir(parents=True)
        for file_name, text in files.items():
            (project / file_name).write_text(text)
        self.run_dir = self.tmp / "run"
        self.run_dir.mkdir()
        self.endpoints = BusEndpoints.ipc(self.run_dir, direct=direct)  # as its [bus] says
        self.sub = Subscriber(self.endpoints, prefixes=list(prefixes), name="bench")
        self.sub.start(on_message)
        self.pub = Publisher(self.endpoints, src="bench", batching=False)
        self.log_path = self.tmp / "supervise.log"
        self.log = self.log_path.open("w")
        self.proc = subprocess.Popen(
            python_module("mrss", "supervise", name, "--run-dir", str(self.run_dir)),
            env={**os.environ, "MRSS_PROJECTS": str(self.tmp / "projects")},
            stdout=self.log, stderr=subprocess.STDOUT, start_new_session=True,
            preexec_fn=lambda: favour(nice, realtime))

    def close(self) -> None:
        try:
            if self.proc.poll() is None:
                self.proc.send_signal(signal.SIGTERM)
                try:
                    self.proc.wait(timeout=30)
                except subprocess.TimeoutExpired:
                    os.killpg(self.proc.pid, signal.SIGKILL)
                    self.proc.wait(timeout=10)
        finally:
            self.sub.close()
            self.pub.close()
            self.log.close()
            shutil.rmtree(self.tmp, ignore_errors=True)


def favour(nice: int | None, realtime: int | None, pid: int = 0) -> None:
    """Set this process's (or thread `pid`'s) nice value and SCHED_RR priority, if given."""
    if nice is not None:
        os.setpriority(os.PRIO_PROCESS, pid, nice)
    if realtime is not None:
        os.sched_setscheduler(pid, os.SCHED_RR, os.sched_param(realtime))
