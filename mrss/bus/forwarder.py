"""The bus proxy: an XSUB/XPUB forwarder that every publisher and subscriber connects to.

`run_proxy` runs one in the calling thread, `ProxyThread` on a background thread; the
proxy process is `python -m mrss.bus.proxy` (mrss/bus/proxy.py).

A proxy killed with SIGKILL leaves its ipc socket files behind; the next proxy on the
same endpoints removes them, unless a live proxy still answers there (then BusError).
Clients need not be restarted: ZeroMQ reconnects them, subscribers re-send their
subscriptions, and the proxy subscribes its frontend to everything, so publishers
forward every message as soon as they are reconnected.
"""

from __future__ import annotations

import socket
import threading
import uuid
from collections.abc import Callable
from pathlib import Path

import zmq

from mrss.bus import sockets
from mrss.bus.direct import WELCOME_DIRECT
from mrss.bus.endpoints import BusEndpoints
from mrss.bus.introducer import introduce
from mrss.bus.wire import WELCOME
from mrss.errors import BusError

log = sockets.log


def run_proxy(
    endpoints: BusEndpoints, *, stop: threading.Event | None = None,
    ready: Callable[[], None] | None = None, hwm: int = sockets.DEFAULT_HWM,
    context: sockets.Context | None = None, fresh: bool = False,
) -> None:
    """Bind both endpoints and forward messages until `stop` is set (forever if None).

    `ready` is called once both endpoints are bound. Raises BusError when an endpoint
    cannot be bound (in use, bad address). `fresh`: no earlier proxy served these
    endpoints in this run, so a direct proxy need not wait for clients to reconnect
    (mrss/bus/introducer.py); leave it False when unsure (a restart), which is safe.
    """
    ctx = sockets.context(context)
    for path in endpoints.ipc_paths():
        clear_stale_socket(path)
    frontend = ctx.socket(zmq.XSUB)
    backend = ctx.socket(zmq.XPUB)
    control = ctx.socket(zmq.PAIR)
    steer = ctx.socket(zmq.PAIR)
    all_sockets = (frontend, backend, control, steer)
    bound: list[str] = []
    try:
        for sock in all_sockets:
            sock.setsockopt(zmq.LINGER, 0)
        frontend.setsockopt(zmq.RCVHWM, hwm)
        backend.setsockopt(zmq.SNDHWM, hwm)
        backend.setsockopt(zmq.XPUB_WELCOME_MSG, WELCOME_DIRECT if endpoints.direct
                           else WELCOME)
        for sock, endpoint in ((frontend, endpoints.frontend), (backend, endpoints.backend)):
            bind_endpoint(sock, endpoint)
            bound.append(endpoint)
        # Take everything from publishers; subscribers' filters apply at the backend.
        # Direct: take nothing; its marker, a little later, tells publishers to deliver
        # directly (mrss/bus/introducer.py).
        if not endpoints.direct:
            frontend.send(b"\x01")
        # unique: id() may repeat while a closed socket's inproc name is still taken
        control_ep = f"inproc://mrss-proxy-control-{uuid.uuid4().hex}"
        control.bind(control_ep)
        steer.connect(control_ep)
        forwarder = threading.Thread(
            target=introduce if endpoints.direct else _forward,
            args=(frontend, backend, control, *((fresh,) if endpoints.direct else ())),
            name="mrss-bus-proxy", daemon=True)
        forwarder.start()
        log.info("bus proxy: frontend %s, backend %s", endpoints.frontend, endpoints.backend)
        if ready is not None:
            ready()
        (stop or threading.Event()).wait()
        steer.send(b"TERMINATE")
        forwarder.join(timeout=5)
    finally:
        for sock in all_sockets:
            sock.close(0)
        for path in BusEndpoints.paths_of(bound):
            path.unlink(missing_ok=True)


class ProxyThread:
    """A proxy on a background thread of this process, e.g. for tests: a context manager."""

    def __init__(self, endpoints: BusEndpoints, *, context: sockets.Context | None = None,
                 fresh: bool = False) -> None:
        self.endpoints = endpoints
        self._context = context
        self._fresh = fresh
        self._stop = threading.Event()
        self._ready = threading.Event()
        self._error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, name="mrss-bus-proxy-main",
                                        daemon=True)

    def _run(self) -> None:
        try:
            run_proxy(self.endpoints, stop=self._stop, ready=self._ready.set,
                      context=self._context, fresh=self._fresh)
        except BaseException as exc:
            self._error = exc
            self._ready.set()

    def start(self, timeout: float = 10.0) -> ProxyThread:
        """Start and wait until bound; re-raises the proxy's BusError."""
        self._thread.start()
        if not self._ready.wait(timeout):
            raise BusError(f"bus proxy did not start within {timeout}s")
        if self._error is not None:
            raise self._error
        return self

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(timeout=10)

    def __enter__(self) -> ProxyThread:
        return self.start()

    def __exit__(self, *exc_info: object) -> None:
        self.stop()


def _forward(frontend: sockets.Socket, backend: sockets.Socket, control: sockets.Socket) -> None:
    try:
        zmq.proxy_steerable(frontend, backend, None, control)
    except zmq.ZMQError as exc:
        if exc.errno != zmq.ETERM:
            log.error("bus proxy stopped: %s", exc)


def bind_endpoint(sock: sockets.Socket, endpoint: str) -> None:
    try:
        sock.bind(endpoint)
    except zmq.ZMQError as exc:
        raise BusError(f"cannot bind bus endpoint {endpoint}: {exc}") from exc


def clear_stale_socket(path: Path) -> None:
    """Remove a socket file left by a killed proxy; refuse to steal a live one."""
    path.parent.mkdir(parents=True, exist_ok=True)
    if not path.exists():
        return
    probe = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    try:
        probe.settimeout(0.5)
        probe.connect(str(path))
    except OSError:
        path.unlink(missing_ok=True)
        return
    finally:
        probe.close()
    raise BusError(f"another bus proxy is listening on ipc://{path}")
