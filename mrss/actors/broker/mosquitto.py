"""Mosquitto as the embedded broker: a child process of the broker component, with its
sessions persisted in the run folder.

`MosquittoProcess(binary, state_dir)` writes `state_dir/mosquitto.conf` and runs
Mosquitto on one loopback listener (or the configured host) with persistence on:
`persistence_location` is `state_dir`, and `autosave_on_changes true` with
`autosave_interval` N (`[broker.embedded] autosave_changes`, default 1) makes Mosquitto
write its database after every N changes (a subscription, a message queued for a
client), not every half hour. A restarted component starts Mosquitto on the same port
with the same file, so a persistent session (the events manager's QoS 1 subscription)
and the messages queued in it survive a broker restart.

What is durable when (Mosquitto 2.0; measurements in docs/edges.md): Mosquitto saves
at the top of its event loop, after the iteration that acknowledged (PUBACK) a message;
so a message is on disk by the time Mosquitto acknowledges anything received after it
(a later PUBACK, a PINGRESP), in practice 1-20 ms after its own PUBACK. A SIGKILL inside
that window loses it although it was acknowledged; a SIGTERM (an orderly stop, or the
component dying: Mosquitto gets SIGTERM then, `PR_SET_PDEATHSIG`) writes everything.

The child is watched: when Mosquitto exits by itself (killed, crashed), the component's
incarnation fails (`on_exit`), and the supervisor restarts the component, which starts a
new Mosquitto from the file. A Mosquitto of an earlier incarnation still running (its
pid is in `state_dir/mosquitto.pid`) is waited for (it is saving) before the new one
starts, so two never write the file at once.
"""

from __future__ import annotations

import contextlib
import ctypes
import logging
import os
import pwd
import signal
import socket
import subprocess
import threading
import time
from collections.abc import Callable
from pathlib import Path

import psutil

log = logging.getLogger("mrss.broker.mosquitto")
DB_FILE = "mosquitto.db"
PID_FILE = "mosquitto.pid"
_PR_SET_PDEATHSIG = 1


def mosquitto_config(host: str, port: int, state_dir: Path, autosave_changes: int) -> str:
    """The configuration file's text: one listener, anonymous clients (as the amqtt
    broker), persistence in `state_dir` saved after every `autosave_changes` changes."""
    return (f"listener {port} {host}\n"
            "allow_anonymous true\n"
            # as root, Mosquitto would otherwise switch to user 'mosquitto'
            f"user {pwd.getpwuid(os.geteuid()).pw_name}\n"
            "persistence true\n"
            f"persistence_location {state_dir}/\n"
            f"persistence_file {DB_FILE}\n"
            "autosave_on_changes true\n"
            f"autosave_interval {autosave_changes}\n"
            "set_tcp_nodelay true\n"
            "log_dest stderr\nlog_type error\nlog_type warning\n")


def _die_with_parent() -> None:  # pragma: no cover (runs in the child before exec)
    """In the child: SIGTERM when the component process ends, even by SIGKILL."""
    libc = ctypes.CDLL(None, use_errno=True)
    libc.prctl(_PR_SET_PDEATHSIG, signal.SIGTERM, 0, 0, 0)


class MosquittoProcess:
    """One Mosquitto child serving `host:port` with its database in `state_dir`."""

    def __init__(self, binary: str, state_dir: Path, *, autosave_changes: int = 1) -> None:
        self.binary = binary
        self.state_dir = state_dir
        self.autosave_changes = autosave_changes
        self.proc: subprocess.Popen[bytes] | None = None
        self._stopping = False
        self._stderr: list[str] = []
        self._watcher: threading.Thread | None = None

    @property
    def db_path(self) -> Path:
        """The persistence file."""
        return self.state_dir / DB_FILE

    def start(self, host: str, port: int, on_exit: Callable[[str], None],
              timeout: float = 20.0) -> None:
        """Start Mosquitto and wait until it accepts connections; `on_exit(reason)` is
        called if it later exits without `stop`. OSError/RuntimeError when it cannot."""
        self.state_dir.mkdir(parents=True, exist_ok=True)
        self._wait_for_previous(timeout)
        conf = self.state_dir / "mosquitto.conf"
        conf.write_text(mosquitto_config(host, port, self.state_dir, self.autosave_changes),
                        encoding="utf-8")
        deadline = time.monotonic() + timeout
        while True:
            self._stderr = []
            self.proc = subprocess.Popen(
                [self.binary, "-c", str(conf)], stdin=subprocess.DEVNULL,
                stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                preexec_fn=_die_with_parent)  # noqa: PLW1509 (prctl only, before exec)
            (self.state_dir / PID_FILE).write_text(f"{self.proc.pid}\n", encoding="utf-8")
            threading.Thread(target=self._read_stderr, args=(self.proc,), daemon=True,
                             name="mosquitto-log").start()
            if self._accepting(host, port, deadline):
                break
            self.proc.wait()
            # the port of the previous incarnation may be closing: try again until timeout
            if time.monotonic() >= deadline:
                raise RuntimeError(f"mosquitto did not start on {host}:{port}: "
                                   f"{' '.join(self._stderr[-3:]) or 'no message'}")
            time.sleep(0.1)
        log.info("embedded MQTT broker (mosquitto, pid %d) listening on %s:%d, sessions "
                 "persisted in %s", self.proc.pid, host, port, self.db_path)
        self._watcher = threading.Thread(target=self._watch, args=(self.proc, on_exit),
                                         daemon=True, name="mosquitto-watch")
        self._watcher.start()

    def _accepting(self, host: str, port: int, deadline: float) -> bool:
        """Wait until the listener accepts (True), or the process ended (False)."""
        assert self.proc is not None
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                return False
            try:
                with socket.create_connection((host, port), timeout=0.2):
                    return True
            except OSError:
                time.sleep(0.02)
        self.proc.kill()
        return False

    def _wait_for_previous(self, timeout: float) -> None:
        """A Mosquitto of an earlier incarnation may still be saving (its parent died and
        it got SIGTERM): wait for it to end, so two never write the file at once. Ended
        means gone or a zombie: orphaned, it is the root supervisor's child (a subreaper)
        now, which reaps it in its own time; waiting for the pid to vanish would wait for
        the supervisor, itself waiting for this start."""
        with contextlib.suppress(OSError, ValueError):
            pid = int((self.state_dir / PID_FILE).read_text(encoding="utf-8").strip())
            try:
                old = psutil.Process(pid)
                if Path(old.exe()).name != Path(self.binary).name:
                    return
            except (psutil.Error, OSError):
                return
            log.info("waiting for mosquitto pid %d of an earlier incarnation to end "
                     "(it saves its sessions)", pid)
            deadline = time.monotonic() + timeout
            while time.monotonic() < deadline:
                try:
                    if old.status() == psutil.STATUS_ZOMBIE:
                        return
                except psutil.NoSuchProcess:
                    return
                time.sleep(0.02)
            log.warning("mosquitto pid %d of an earlier incarnation still runs after "
                        "%.0f s; killing it", pid, timeout)
            with contextlib.suppress(psutil.Error):
                old.kill()

    def _read_stderr(self, proc: subprocess.Popen[bytes]) -> None:
        assert proc.stderr is not None
        for raw in proc.stderr:
            line = raw.decode("utf-8", "replace").strip()
            if line:
                self._stderr.append(line)
                del self._stderr[:-20]
                log.warning("mosquitto: %s", line)

    def _watch(self, proc: subprocess.Popen[bytes], on_exit: Callable[[str], None]) -> None:
        code = proc.wait()
        if not self._stopping:
            reason = f"mosquitto (pid {proc.pid}) exited with code {code}"
            log.error("%s", reason)
            on_exit(reason)

    @property
    def running(self) -> bool:
        return self.proc is not None and self.proc.poll() is None

    def stop(self, timeout: float = 10.0) -> None:
        """SIGTERM (Mosquitto writes its database), SIGKILL after `timeout`."""
        self._stopping = True
        proc = self.proc
        if proc is None:
            return
        if proc.poll() is None:
            proc.terminate()
            try:
                proc.wait(timeout)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        if self._watcher is not None:
            self._watcher.join(timeout=5)
