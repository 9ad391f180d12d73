"""How component processes are started: exec a fresh interpreter, or fork a template.

Both launchers hand the child one end of its control socket and report every exit of a
child they started, with the reason from its wait status, through `on_exit(pid, reason)`.
They register their own file descriptors with the supervisor's selector; the key's data
is a callable the supervisor loop calls when the descriptor is readable.
"""

from __future__ import annotations

import json
import logging
import os
import selectors
import socket
import subprocess
import sys
import time
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any

from mrss.errors import SupervisionError
from mrss.interpreter import python_module
from mrss.supervision.reason import Cause, ExitReason

log = logging.getLogger("mrss.supervision.launchers")

# The exit of a child whose fork server died first: only its parent could have read why.
_STATUS_LOST = ExitReason(Cause.EXITED, "exit status unknown (its fork server was lost)")

OnExit = Callable[[int, ExitReason], None]
OnServerLost = Callable[[str, int], None]  # (why, how many of its children live on)


class Launcher:
    """Starts component processes and reports their exits."""

    def __init__(self, selector: selectors.BaseSelector, on_exit: OnExit) -> None:
        self.selector = selector
        self.on_exit = on_exit

    def spawn(self, target: str, name: str, inc: int, context: str,
              control: socket.socket) -> int:
        """Start one incarnation; returns its pid (SupervisionError if it cannot)."""
        raise NotImplementedError

    def flush(self) -> None:
        """Report exits that were read while doing something else (called by the loop)."""

    def close(self) -> None:
        """Release the launcher (children must already be stopped)."""


class ExecLauncher(Launcher):
    """`python -P -m mrss.runtime.main ...` per start; exits seen via pidfd."""

    def __init__(self, selector: selectors.BaseSelector, on_exit: OnExit,
                 python: str = sys.executable) -> None:
        super().__init__(selector, on_exit)
        self.python = python
        self._procs: dict[int, tuple[subprocess.Popen[bytes], int]] = {}

    def spawn(self, target: str, name: str, inc: int, context: str,
              control: socket.socket) -> int:
        fd = control.fileno()
        argv = python_module("mrss.runtime.main", target, "--name", name,
                             "--inc", str(inc), "--context", context, "--control-fd", str(fd),
                             python=self.python)
        try:
            proc = subprocess.Popen(argv, pass_fds=(fd,), stdin=subprocess.DEVNULL,
                                    process_group=0)
        except OSError as exc:
            raise SupervisionError(f"cannot start {name}: {exc}") from exc
        pidfd = os.pidfd_open(proc.pid)
        self._procs[pidfd] = (proc, pidfd)
        self.selector.register(pidfd, selectors.EVENT_READ, lambda: self._reap(pidfd))
        return proc.pid

    def _reap(self, pidfd: int) -> None:
        proc, _ = self._procs.pop(pidfd)
        self.selector.unregister(pidfd)
        os.close(pidfd)
        code = proc.wait()
        self.on_exit(proc.pid, ExitReason.from_returncode(code))

    def close(self) -> None:
        for pidfd, (proc, _) in list(self._procs.items()):
            self.selector.unregister(pidfd)
            os.close(pidfd)
            if proc.poll() is None:
                proc.kill()
                proc.wait()
        self._procs.clear()


class ForkLauncher(Launcher):
    """Forks children from a fork server that imported everything once (fast restarts).

    Losing the fork server is one launcher restart, not a failure of its children: they
    are separate processes with their own control channels to the supervisor, so they
    keep running. Under `mrss supervise` the root's process is their child subreaper
    (`become_subreaper`), so they are re-parented to it and stay in its process tree;
    their exits are then watched through pidfds and reaped here with their real status
    (reported as unknown where the supervisor is not their subreaper). A new fork server
    is started at once for the next spawn; `on_server_lost(why, kept)` tells the
    supervisor.

    Made before its supervisor (`ForkLauncher.early`), it starts the fork server at once,
    so that the server imports the component code while the root sets itself up; `check`
    then has it check the project, and the supervisor takes it over (`attach`).
    """

    def __init__(self, selector: selectors.BaseSelector, on_exit: OnExit,
                 preload: Sequence[str] = (), path: Sequence[str | Path] = (),
                 python: str = sys.executable, start_timeout: float = 30.0,
                 on_server_lost: OnServerLost | None = None) -> None:
        super().__init__(selector, on_exit)
        self.preload = list(preload)
        self.path = [str(p) for p in path]
        self.python = python
        self.start_timeout = start_timeout
        self.on_server_lost = on_server_lost
        self.servers_lost = 0
        self._sock: socket.socket | None = None
        self._server: subprocess.Popen[bytes] | None = None
        self._hello = False
        self._children: set[int] = set()
        self._orphans: dict[int, int] = {}  # pidfd -> pid of a lost server's child
        self._req = 0
        self._exits: list[tuple[int, ExitReason]] = []

    @classmethod
    def early(cls, preload: Sequence[str], path: Sequence[str | Path]) -> ForkLauncher:
        """A launcher whose fork server starts now, before there is a supervisor (which
        `attach`es it); it has no children until then."""
        launcher = cls(selectors.DefaultSelector(), _no_children, preload=preload, path=path)
        launcher._launch()
        return launcher

    def attach(self, selector: selectors.BaseSelector, on_exit: OnExit,
               on_server_lost: OnServerLost | None) -> None:
        """Hand this launcher (made `early`) to a supervisor's loop."""
        if self._sock is not None:
            self.selector.unregister(self._sock)
            selector.register(self._sock, selectors.EVENT_READ, self._readable)
        self.selector.close()
        self.selector, self.on_exit, self.on_server_lost = selector, on_exit, on_server_lost

    def check(self, target: str, project_file: Path) -> bool:
        """Have the fork server run the check `target` ("pkg.mod:function", called with the
        project file, True when it may start) in a child of its own (its findings go to
        stderr). SupervisionError if the server cannot answer."""
        self.start()
        assert self._sock is not None
        self._req += 1
        n = self._req
        try:
            self._sock.send(json.dumps({"op": "check", "req": n, "target": target,
                                        "file": str(project_file)}).encode())
        except OSError as exc:
            self._server_lost(f"send failed: {exc}")
            raise SupervisionError("cannot check the project: fork server is gone") from exc
        reply = self._wait_reply(lambda m: m.get("op") == "checked" and m.get("req") == n)
        return bool(reply.get("ok"))

    @property
    def server_pid(self) -> int:
        return self._server.pid if self._server else 0

    def start(self) -> None:
        """Start the fork server now and wait for its hello (otherwise a spawn does)."""
        self._launch()
        if not self._hello:
            hello = self._wait_reply(lambda m: m.get("op") == "hello")
            self._hello = True
            log.debug("fork server up, pid %s", hello.get("pid"))

    def _launch(self) -> None:
        """Start a fork server process without waiting for it to finish its imports."""
        if self._sock is not None:
            return
        ours, theirs = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
        argv = python_module("mrss.runtime.forkserver", "--fd", str(theirs.fileno()),
                             "--preload", ",".join(self.preload), python=self.python)
        for p in self.path:
            argv += ["--path", p]
        try:
            self._server = subprocess.Popen(argv, pass_fds=(theirs.fileno(),),
                                            stdin=subprocess.DEVNULL)
        except OSError as exc:
            ours.close()
            raise SupervisionError(f"cannot start the fork server: {exc}") from exc
        finally:
            theirs.close()
        self._sock, self._hello = ours, False
        self.selector.register(ours, selectors.EVENT_READ, self._readable)

    def spawn(self, target: str, name: str, inc: int, context: str,
              control: socket.socket) -> int:
        lost = self.servers_lost
        try:
            return self._spawn_once(target, name, inc, context, control)
        except SupervisionError:
            if self.servers_lost == lost:
                raise
            log.warning("fork server lost while starting %s; asking the new one", name)
            return self._spawn_once(target, name, inc, context, control)

    def _spawn_once(self, target: str, name: str, inc: int, context: str,
                    control: socket.socket) -> int:
        self.start()
        assert self._sock is not None
        self._req += 1
        req = {"op": "spawn", "req": self._req, "target": target, "name": name, "inc": inc,
               "context": context}
        try:
            socket.send_fds(self._sock, [json.dumps(req).encode()], [control.fileno()])
        except OSError as exc:
            self._server_lost(f"send failed: {exc}")
            raise SupervisionError(f"cannot start {name}: fork server is gone") from exc
        n = self._req
        reply = self._wait_reply(lambda m: m.get("req") == n and m.get("op") != "exit")
        if reply.get("op") != "spawned":
            raise SupervisionError(f"cannot start {name}: {reply.get('error', reply)}")
        pid = int(reply["pid"])
        self._children.add(pid)
        return pid

    def _wait_reply(self, wanted: Callable[[dict[str, Any]], bool]) -> dict[str, Any]:
        """Read until a wanted message; exits read meanwhile are kept for the loop."""
        assert self._sock is not None
        deadline = time.monotonic() + self.start_timeout
        self._sock.settimeout(self.start_timeout)
        try:
            while True:
                if time.monotonic() > deadline:
                    raise SupervisionError("fork server did not answer")
                try:
                    data = self._sock.recv(1 << 16)
                except OSError as exc:
                    raise SupervisionError(f"fork server is gone: {exc}") from exc
                if not data:
                    self._server_lost("closed its channel")
                    raise SupervisionError("fork server is gone")
                msg = json.loads(data)
                if wanted(msg):
                    return dict(msg)
                self._note(msg)
        finally:
            if self._sock is not None:
                self._sock.settimeout(None)

    def _readable(self) -> None:
        assert self._sock is not None
        self._sock.setblocking(False)
        try:
            while True:
                try:
                    data = self._sock.recv(1 << 16)
                except BlockingIOError:
                    break
                except OSError:
                    data = b""
                if not data:
                    self._server_lost("closed its channel")
                    break
                self._note(json.loads(data))
        finally:
            if self._sock is not None:
                self._sock.setblocking(True)
        self.flush()

    def _note(self, msg: dict[str, Any]) -> None:
        if msg.get("op") == "hello":
            self._hello = True
        elif msg.get("op") == "exit":
            pid = int(msg["pid"])
            self._children.discard(pid)
            self._exits.append((pid, ExitReason.from_wait_status(int(msg["status"]))))

    def flush(self) -> None:
        pending, self._exits = self._exits, []
        for pid, reason in pending:
            self.on_exit(pid, reason)

    def _server_lost(self, why: str) -> None:
        """The fork server died: watch its children by pidfd, start a new server now."""
        if self._sock is not None:
            try:
                self.selector.unregister(self._sock)
            except (KeyError, ValueError):
                pass
            self._sock.close()
            self._sock = None
        status = "gone"
        if self._server is not None:
            self._server.kill()
            status = str(ExitReason.from_returncode(self._server.wait()))
            self._server = None
        kept = 0
        for pid in sorted(self._children):
            try:
                pidfd = os.pidfd_open(pid)
            except OSError:  # already gone: its exit report went with the server
                self._exits.append((pid, _reap(pid)))
                continue
            self._orphans[pidfd] = pid
            self.selector.register(pidfd, selectors.EVENT_READ,
                                   lambda fd=pidfd: self._orphan_exited(fd))
            kept += 1
        self._children.clear()
        self.servers_lost += 1
        log.error("fork server lost (%s, %s); %d of its children keep running; starting a "
                  "new one", why, status, kept)
        try:
            self._launch()
        except SupervisionError as exc:  # the next spawn tries again
            log.error("%s", exc)
        if self.on_server_lost is not None:
            self.on_server_lost(f"{why} ({status})", kept)

    def _orphan_exited(self, pidfd: int) -> None:
        pid = self._orphans.pop(pidfd)
        self.selector.unregister(pidfd)
        os.close(pidfd)
        self._exits.append((pid, _reap(pid)))
        self.flush()

    def close(self) -> None:
        for pidfd in list(self._orphans):
            self.selector.unregister(pidfd)
            os.close(pidfd)
        self._orphans.clear()
        if self._sock is not None:
            try:
                self.selector.unregister(self._sock)
            except (KeyError, ValueError):
                pass
            self._sock.close()
            self._sock = None
        if self._server is not None:
            try:
                self._server.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self._server.kill()
                self._server.wait()
            self._server = None


def _no_children(pid: int, reason: ExitReason) -> None:
    """An early launcher's exit handler: it starts no component before it is attached."""
    log.warning("exit of pid %d reported before the supervisor took over: %s", pid, reason)


def preload_modules(targets: Iterable[str]) -> list[str]:
    """The modules a fork server imports ahead for components `pkg.mod:Class`."""
    return sorted({target.partition(":")[0] for target in targets})


def become_subreaper() -> None:
    """Make this process adopt its orphaned descendants (prctl PR_SET_CHILD_SUBREAPER):
    the children of a lost fork server stay in the supervisor's tree and are reaped here."""
    if not sys.platform.startswith("linux"):
        return
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        if libc.prctl(36, 1, 0, 0, 0) != 0:  # PR_SET_CHILD_SUBREAPER
            log.warning("cannot become a child subreaper (errno %d)", ctypes.get_errno())
    except OSError as exc:
        log.warning("cannot become a child subreaper: %s", exc)


def _reap(pid: int) -> ExitReason:
    """The exit of an adopted child of a lost fork server, reaped if it is ours."""
    try:
        done, status = os.waitpid(pid, os.WNOHANG)
    except ChildProcessError:  # not re-parented to us: its status went with the server
        return _STATUS_LOST
    return ExitReason.from_wait_status(status) if done == pid else _STATUS_LOST
