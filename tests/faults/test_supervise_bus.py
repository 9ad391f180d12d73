"""`mrss supervise` with the bus: the proxy is a component, sup.* events go on the bus."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import psutil

from mrss.bus import BusEndpoints, Publisher, Subscriber
from mrss.messages import Envelope, LogRecord, SupEvent, SupEventKind
from mrss.testing import wait_until

PROJECTS = Path(__file__).resolve().parent.parent / "projects"


def test_supervised_components_speak_on_the_bus_and_restarts_are_published(
        tmp_path: Path) -> None:
    seen: list[Envelope] = []
    sub = Subscriber(BusEndpoints.ipc(tmp_path), prefixes=["sup.", "log."])
    sub.start(seen.append)
    proc = subprocess.Popen(
        [sys.executable, "-m", "mrss", "supervise", "busdemo", "--run-dir", str(tmp_path)],
        env={**os.environ, "MRSS_PROJECTS": str(PROJECTS)}, stdout=subprocess.PIPE,
        stderr=subprocess.PIPE, text=True)
    try:
        def announced(inc: int) -> bool:
            return any(isinstance(e.body, LogRecord)
                       and e.body.message == f"started incarnation {inc}" for e in seen)

        def restarted() -> bool:  # its new words, and the supervisor's word it started
            return announced(2) and any(
                isinstance(e.body, SupEvent) and e.body.event == "start"
                and e.body.child == "announcer" and e.body.detail.get("inc") == 2 for e in seen)

        wait_until(lambda: (tmp_path / "announcer.1.started").exists(), timeout=30,
                   message="announcer started")
        # what was published before this subscriber joined the proxy is not ours to see;
        # the welcome alone does not mean its subscriptions have reached the proxy
        wait_until(lambda: sub.wait_connected(timeout=0.5), timeout=10, message="subscribed")
        with Publisher(BusEndpoints.ipc(tmp_path), src="probe") as probe:
            marker = SupEvent(event=SupEventKind.TREE, child="probe")
            wait_until(lambda: probe.publish(marker) and any(
                isinstance(e.body, SupEvent) and e.body.child == "probe" for e in seen),
                timeout=10, interval=0.05, message="subscription in place at the proxy")
        pid = int((tmp_path / "announcer.1.started").read_text())
        os.kill(pid, signal.SIGKILL)
        wait_until(restarted, timeout=30, message="restarted announcer on the bus")
        events = [(e.body.event, e.body.child) for e in seen if isinstance(e.body, SupEvent)]
        mine = [e for e in events if e[1] == "announcer"]
        # the first start may have gone out before this subscriber joined the proxy
        assert mine[-3:] == [("exit", "announcer"), ("restart", "announcer"),
                             ("start", "announcer")]
        exits = [e.body for e in seen if isinstance(e.body, SupEvent)
                 and e.body.event == "exit" and e.body.child == "announcer"]
        assert exits and "SIGKILL" in exits[0].reason
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=30)
        assert proc.returncode == 0, err
    finally:
        sub.close()
        if proc.poll() is None:
            for child in psutil.Process(proc.pid).children(recursive=True):
                child.kill()
            proc.kill()
            proc.communicate(timeout=10)
