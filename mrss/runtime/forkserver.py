"""A pre-imported template process that forks component processes on request.

Starting Python and importing MRSS costs far more than a restart should; the fork
server pays it once. It is started by the root supervisor with one end of a
SOCK_SEQPACKET pair, imports the component modules ahead of time, then serves:

  supervisor -> server: {"op": "spawn", "req": N, "target", "name", "inc", "context"}
                        plus the child's control socket (SCM_RIGHTS)
                        {"op": "check", "req": N, "target": "pkg.mod:fn", "file": F}
  server -> supervisor: {"op": "spawned", "req": N, "pid": P} | {"op": "error", ...}
                        {"op": "exit", "pid": P, "status": S}  (raw waitpid status)
                        {"op": "checked", "req": N, "ok": BOOL}

A check (`mrss supervise` names `mrss check`'s, run before anything starts) runs in a
forked child too, so it finds the project's classes already imported and leaves the
server's own memory as it was; the child prints its findings on the inherited stderr.
The root therefore never imports component code itself.

Forked children get their own process group; the server exits when the supervisor's end
closes, and a child whose supervisor is gone stops itself (its control channel closes).
It never creates threads or sockets beyond its channel before forking, so children start
from a clean template.
"""

from __future__ import annotations

import argparse
import gc
import importlib
import json
import logging
import os
import select
import signal
import socket
import sys
from collections.abc import Callable, Sequence
from typing import Any

log = logging.getLogger("mrss.runtime.forkserver")

PRELOAD = ("mrss.runtime.main", "mrss.messages", "pykka", "msgpack", "zmq")
# Called after the imports when their module was imported: what children would each build
# on their own (the AgentSpeak parser: the reasoner, the check, percept parsing).
WARM = (("mrss.agentspeak.parser", "warm"),)


COMPONENT_COMM_PREFIX = "mrss:"  # a forked component's process name: "mrss:reasoner"


def is_fork_server(cmdline: Sequence[str], name: str) -> bool:
    """Whether a process (its argv and its name) is a fork server, not a component it
    forked: those share its argv, but name themselves after their component."""
    return (any("mrss.runtime.forkserver" in part for part in cmdline)
            and not name.startswith(COMPONENT_COMM_PREFIX))


def _name_process(name: str) -> None:
    """Set the process name (`ps`, `top`, psutil's name()) to `mrss:<component>`."""
    if not sys.platform.startswith("linux"):
        return
    try:
        import ctypes

        libc = ctypes.CDLL(None)
        libc.prctl(15, f"{COMPONENT_COMM_PREFIX}{name}"[:15].encode(), 0, 0, 0)  # PR_SET_NAME
    except OSError:
        pass


def _forked(sock: socket.socket, wake: tuple[int, int], what: str,
            body: Callable[[], int]) -> None:
    """In a forked child: drop the server's signal handling and descriptors, run `body`,
    exit with its code; anything raised is logged as `what` failed and exits 1. Never
    returns: a forked child must end in os._exit."""
    code = 1
    try:
        signal.set_wakeup_fd(-1)
        signal.signal(signal.SIGCHLD, signal.SIG_DFL)
        sock.close()
        os.close(wake[0])
        os.close(wake[1])
        code = body()
    except BaseException:  # anything, in a forked child, must end in os._exit
        logging.getLogger("mrss.runtime.forkserver").exception("%s failed", what)
    finally:
        try:
            sys.stdout.flush()
            sys.stderr.flush()
        finally:
            os._exit(code)


def _child(sock: socket.socket, wake: tuple[int, int], req: dict[str, Any], fd: int) -> None:
    """In the forked child: become a component; never returns."""
    def component() -> int:
        _name_process(str(req["name"]))
        os.setpgid(0, 0)
        from mrss.runtime.main import run_component

        logging.getLogger().handlers.clear()
        logging.basicConfig(
            level=logging.INFO, force=True,
            format=f"%(asctime)s {req['name']}[{os.getpid()}] %(levelname)s %(message)s")
        return run_component(req["target"], req["name"], int(req["inc"]), req["context"], fd)

    _forked(sock, wake, "forked child", component)


def _check(sock: socket.socket, wake: tuple[int, int], target: str, file: str) -> None:
    """In a forked child: run the check `target` ("pkg.mod:function", called with the
    project file; True when it may start, its findings printed on stderr); exit 0 when
    the project may start, 2 when not."""
    def check() -> int:
        module, _, function = target.partition(":")
        return 0 if getattr(importlib.import_module(module), function)(file) else 2

    _forked(sock, wake, "project check", check)


def _send(sock: socket.socket, msg: dict[str, Any]) -> bool:
    try:
        sock.send(json.dumps(msg).encode())
        return True
    except OSError:
        return False


def serve(sock: socket.socket) -> int:
    """The server loop: spawn on request, report exits, stop when the supervisor goes."""
    checks: dict[int, Any] = {}  # pid of a check child -> its request's id
    wake = os.pipe()
    os.set_blocking(wake[1], False)
    os.set_blocking(wake[0], False)
    signal.set_wakeup_fd(wake[1])
    signal.signal(signal.SIGCHLD, lambda *_: None)
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the supervisor decides when we stop
    signal.signal(signal.SIGTERM, lambda *_: None)
    _send(sock, {"op": "hello", "pid": os.getpid()})
    while True:
        try:
            readable, _, _ = select.select([sock.fileno(), wake[0]], [], [])
        except InterruptedError:
            continue
        if wake[0] in readable:
            try:
                os.read(wake[0], 4096)
            except BlockingIOError:
                pass
            _reap(sock, checks)
        if sock.fileno() in readable:
            try:
                data, fds, _, _ = socket.recv_fds(sock, 1 << 20, 1)
            except OSError:
                data, fds = b"", []
            if not data:
                return 0
            _handle(sock, wake, data, fds, checks)


def _reap(sock: socket.socket, checks: dict[int, Any]) -> None:
    while True:
        try:
            pid, status = os.waitpid(-1, os.WNOHANG)
        except ChildProcessError:
            return
        if pid == 0:
            return
        if pid in checks:
            ok = os.WIFEXITED(status) and os.WEXITSTATUS(status) == 0
            _send(sock, {"op": "checked", "req": checks.pop(pid), "ok": ok})
        else:
            _send(sock, {"op": "exit", "pid": pid, "status": status})


def _handle(sock: socket.socket, wake: tuple[int, int], data: bytes, fds: list[int],
            checks: dict[int, Any]) -> None:
    try:
        req = json.loads(data)
        if req.get("op") == "check" and not fds and "target" in req and "file" in req:
            sys.stdout.flush()
            sys.stderr.flush()
            pid = os.fork()
            if pid == 0:
                _check(sock, wake, str(req["target"]), str(req["file"]))
            checks[pid] = req.get("req")
            return
        if req.get("op") != "spawn" or len(fds) != 1:
            raise ValueError("expected a spawn request with one control socket")
    except (ValueError, KeyError) as exc:
        for fd in fds:
            os.close(fd)
        _send(sock, {"op": "error", "req": None, "error": str(exc)})
        return
    sys.stdout.flush()
    sys.stderr.flush()
    pid = os.fork()
    if pid == 0:
        _child(sock, wake, req, fds[0])
    os.close(fds[0])
    _send(sock, {"op": "spawned", "req": req.get("req"), "pid": pid})


def preload(modules: Sequence[str], path: Sequence[str]) -> None:
    """Import what children will need, so a fork starts with it loaded."""
    for p in reversed(path):
        if p and p not in sys.path:
            sys.path.insert(0, p)
    for name in (*PRELOAD, *modules):
        try:
            importlib.import_module(name)
        except Exception as exc:  # the child will import again and report properly
            log.debug("preload of %s failed: %s", name, exc)
    for name, function in WARM:
        if name in sys.modules:
            try:
                getattr(sys.modules[name], function)()
            except Exception as exc:  # the children build it themselves
                log.debug("%s.%s() failed: %s", name, function, exc)


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m mrss.runtime.forkserver")
    p.add_argument("--fd", type=int, required=True, help="inherited SOCK_SEQPACKET socket")
    p.add_argument("--preload", default="", help="comma-separated modules to import")
    p.add_argument("--path", action="append", default=[], help="prepend to sys.path")
    args = p.parse_args(argv)
    gc.disable()  # no collection while importing: fewer freed holes in the shared pages
    preload([m for m in args.preload.split(",") if m], args.path)
    gc.freeze()  # what the children share is never traversed by their collections
    gc.enable()
    return serve(socket.socket(fileno=args.fd))


if __name__ == "__main__":
    sys.exit(main())
