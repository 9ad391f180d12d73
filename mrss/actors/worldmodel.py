"""The embedded world model component: SQLite objects, project rules, bus and HTTP access.

Rules' literals are published as percepts. The data layer reaches the world model with
requests on `dl.request.wm` (see `mrss.edge.worldmodel_service`); user interfaces use the
HTTP JSON API on loopback, whose URL is logged and written to `<run_dir>/worldmodel.url`.

project.toml:
    [worldmodel]
    path = "worldmodel.sqlite"   # in the run folder (default), or ":memory:"
    seed = "world.json"          # objects to load at start, in the project folder
    rules_module = "worldmodel.py"
    http = true                  # serve the HTTP API
    http_host = "127.0.0.1"      # loopback unless configured
    http_port = 0                # 0: a free port
    [[worldmodel.rules]]  ...    # built-in rules (see mrss.edge.worldmodel_service)
The `[components.<id>]` free keys of this component are laid over `[worldmodel]`.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from mrss.edge.busport import BusPort
from mrss.edge.component import bus_port, edge_config, table
from mrss.edge.worldmodel_http import WorldModelHttp
from mrss.edge.worldmodel_rules import RuleEngine
from mrss.edge.worldmodel_service import (
    WM_REPLY_TOPIC,
    WM_REQUEST_TOPIC,
    WorldModel,
    load_rules,
    load_seed,
)
from mrss.edge.worldmodel_store import WorldModelStore
from mrss.errors import ConfigError
from mrss.messages import DataRequest, Envelope, Percept
from mrss.supervision.component import Component, ComponentContext

log = logging.getLogger("mrss.worldmodel")
URL_FILE = "worldmodel.url"


def store_path(run_dir: Path | None, section: Mapping[str, Any]) -> str:
    """Where the SQLite file goes: `path` under the run folder, or ':memory:'."""
    path = section.get("path", "worldmodel.sqlite")
    if not isinstance(path, str) or not path:
        raise ConfigError("must be a file name or ':memory:'", key="worldmodel.path")
    if path == ":memory:" or run_dir is None:
        return ":memory:"
    return str(run_dir / path)


class WorldModelComponent(Component):
    """Component: the world model, its rules, its bus functions and its HTTP API."""

    def __init__(self) -> None:
        self.world: WorldModel | None = None
        self.http: WorldModelHttp | None = None
        self._bus: BusPort | None = None
        self._url_file: Path | None = None

    def start(self, ctx: ComponentContext) -> None:
        """Component entry: bus from the context, then `run`."""
        bus = bus_port(ctx)
        self.run(ctx.project_dir, ctx.run_dir, edge_config(ctx, "worldmodel"), bus)
        bus.wait_connected(5.0)  # ready means requests are heard

    def run(self, project_dir: Path | None, run_dir: Path | None, config: Mapping[str, Any],
            bus: BusPort) -> None:
        """Open the store, load rules and seed, serve the bus and (optionally) HTTP."""
        section = table(config, "worldmodel")
        rules = RuleEngine(load_rules(project_dir, section))
        self._bus = bus

        def emit(text: str) -> None:
            bus.publish(Percept(literal=text))

        self.world = WorldModel(WorldModelStore(store_path(run_dir, section)), rules, emit)
        seeded = load_seed(self.world, project_dir, section)
        bus.subscribe([WM_REQUEST_TOPIC], self._on_request)
        if section.get("http", True):
            host = section.get("http_host", "127.0.0.1")
            port = section.get("http_port", 0)
            if not isinstance(host, str) or not isinstance(port, int):
                raise ConfigError("http_host must be a string and http_port an integer",
                                  key="worldmodel.http_port")
            self.http = WorldModelHttp(self.world, host, port)
            self.http.start()
            if run_dir is not None:
                self._url_file = run_dir / URL_FILE
                self._url_file.write_text(self.http.url + "\n")
        log.info("world model up: %d rules, %d seeded objects, HTTP %s", len(rules.rules),
                 seeded, self.http.url if self.http else "off")

    def _on_request(self, env: Envelope) -> None:
        body = env.body
        if env.topic != WM_REQUEST_TOPIC or not isinstance(body, DataRequest):
            return
        assert self.world is not None and self._bus is not None
        self._bus.publish(self.world.handle(body), topic=WM_REPLY_TOPIC)

    def stop(self) -> None:
        """Stop HTTP and the bus handlers, close the store."""
        if self.http is not None:
            self.http.stop()
        if self._url_file is not None:
            self._url_file.unlink(missing_ok=True)
        if self._bus is not None:
            self._bus.close()
        if self.world is not None:
            self.world.store.close()
