"""The Foxglove component: the live bus as a Foxglove WebSocket server (Foxglove SDK).

```toml
[components.foxglove]        # optional: a project without it has no server
kind = "foxglove"
host = "127.0.0.1"           # loopback only (below)
port = 8765                  # 0: a free port; the URL goes to <run_dir>/foxglove.url
prefixes = [""]              # bus topics sent, by prefix
```

An engineer opens Foxglove on the command-post machine, connects to
`ws://127.0.0.1:8765` (protocol `foxglove.websocket.v1`), and gets the channels and
schemas of an MCAP recording (`bridge.py`), live: the robots on the Map panel, plots of
battery, altitude or tank, the log and raw messages (docs/foxglove.md has the layout).

The SDK's server cannot authenticate its clients (it offers TLS, which hides the
traffic but lets anyone connect), so a host beyond loopback is refused at start with a
ConfigError naming the key; from another machine, tunnel to it (`ssh -L`). The bus is
read by the recorder's raw subscriber (mrss/recording/recorder.py) on a thread of the
component's own; `stop` ends it and the server.
"""

from __future__ import annotations

import logging
import threading
from pathlib import Path
from typing import ClassVar

import foxglove
from foxglove.websocket import WebSocketServer

from mrss.actors.foxglove.bridge import FoxgloveBridge
from mrss.actors.foxglove.options import FOXGLOVE_OPTIONS, values_of
from mrss.bus import BusEndpoints
from mrss.edge.http_token import is_loopback
from mrss.errors import ConfigError
from mrss.options import Option
from mrss.recording.recorder import BusRecorder
from mrss.runtime.component import Component, ComponentContext
from mrss.textfile import write_whole

log = logging.getLogger("mrss.foxglove")
URL_FILE = "foxglove.url"
CONNECT_TIMEOUT = 10.0  # seconds to wait for the bus proxy's welcome at start


def exposure_problem(host: str) -> str | None:
    """Why serving on `host` is refused (anything but loopback), or None."""
    if is_loopback(host):
        return None
    return (f"{host!r} is not a loopback address: the Foxglove WebSocket server cannot "
            "authenticate its clients, so it only serves this machine; set host = "
            "\"127.0.0.1\" and reach it from elsewhere through a tunnel "
            "(ssh -L 8765:127.0.0.1:8765 <this machine>)")


class FoxgloveComponent(Component):
    """Component: a Foxglove WebSocket server fed with every bus message."""

    OPTIONS: ClassVar[tuple[Option, ...]] = FOXGLOVE_OPTIONS

    def __init__(self) -> None:
        self.server: WebSocketServer | None = None
        self.url = ""
        self.bridge: FoxgloveBridge | None = None
        self._recorder: BusRecorder | None = None
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def start(self, ctx: ComponentContext) -> None:
        values = values_of(ctx.options, ctx.name)
        host, port = values.text("host"), values.whole("port")
        problem = exposure_problem(host)
        if problem:
            raise ConfigError(problem, key=f"components.{ctx.name}.host")
        prefixes = values["prefixes"]
        if not isinstance(prefixes, list) or not all(isinstance(p, str) for p in prefixes):
            raise ConfigError("must be a list of topic prefixes (strings)",
                              key=f"components.{ctx.name}.prefixes")
        self.url = self.serve(host, port, backlog=values.whole("backlog"),
                              name=ctx.project_dir.name)
        self._recorder = BusRecorder(BusEndpoints.from_dict(ctx.bus), prefixes or [""])
        if not self._recorder.wait_connected(CONNECT_TIMEOUT, self._stop):
            raise ConfigError(f"no bus proxy answered within {CONNECT_TIMEOUT:g} s",
                              key="bus")
        self._thread = threading.Thread(target=self._run, name="foxglove-bus", daemon=True)
        self._thread.start()
        write_url(ctx.run_dir, self.url)
        log.info("Foxglove WebSocket server on %s (topics %s)", self.url, prefixes)

    def serve(self, host: str, port: int, *, backlog: int, name: str) -> str:
        """Start the server on its own SDK context; its URL."""
        context = foxglove.Context()
        self.bridge = FoxgloveBridge(context)
        self.server = foxglove.start_server(name=f"mrss {name}", host=host, port=port,
                                            context=context, message_backlog_size=backlog)
        return f"ws://{host}:{self.server.port}"

    def _run(self) -> None:
        assert self._recorder is not None and self.bridge is not None
        self._recorder.record(self.bridge, self._stop, None)

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
        if self._recorder is not None:
            self._recorder.close()
        if self.server is not None:
            self.server.stop()


def write_url(run_dir: Path | None, url: str) -> None:
    """`<run_dir>/foxglove.url`, written whole (a reader never sees half of it)."""
    if run_dir is None:
        return
    write_whole(run_dir / URL_FILE, url + "\n")
