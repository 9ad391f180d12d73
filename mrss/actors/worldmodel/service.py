"""The world model component: objects (embedded SQLite, or PostGIS), project rules, bus and
HTTP access.

Rules' literals are percepts, sent on the reliable channel "percept" with a copy on the
`percept` topic (`mrss.runtime.percept_channel`). The data layer reaches the world model with
requests on `dl.request.wm` (see `mrss.actors.worldmodel.model`); user interfaces use the
HTTP JSON API on loopback, whose URL is logged and written to `<run_dir>/worldmodel.url`.

The HTTP port is stable across incarnations: with `http_port = 0` the first incarnation
of a run binds a free port and records it in `<run_dir>/worldmodel.url`; each later one
binds that port again (SO_REUSEADDR), so clients that kept the URL reconnect. Only if
the port was taken meanwhile does it pick a new one and rewrite the file. The file stays
when the component stops. Clients should still look the URL up per call
(`mrss.world.access.WorldModelClient`, `ExternalAdapter.world_model()`).

project.toml:
    [worldmodel]
    path = "worldmodel.sqlite"   # in the run folder (default), or ":memory:"
    url = "postgresql://mrss@db.example:5432/world"  # PostGIS instead of SQLite (optional)
    seed = "world.json"          # objects to load at start, in the project folder
    rules_module = "worldmodel.py"
    http = true                  # serve the HTTP API
    http_host = "127.0.0.1"      # loopback unless configured (beyond it: a token is required)
    http_port = 0                # 0: a free port
    http_timeout = 10.0          # seconds a connection may take to send its request
    token_file = "secrets/worldmodel.token"   # or token_env = "VAR": requests need
                                 # Authorization: Bearer <token> (mrss.edge.http_token)
    [[worldmodel.rules]]  ...    # built-in rules (see mrss.actors.worldmodel.model)
The `[components.<id>]` free keys of this component are laid over `[worldmodel]`.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, ClassVar
from urllib.parse import urlsplit

from mrss.actors.worldmodel.http import DEFAULT_TIMEOUT, WorldModelHttp
from mrss.actors.worldmodel.model import WorldModel, load_rules, load_seed
from mrss.actors.worldmodel.options import WORLDMODEL_OPTIONS, values_of
from mrss.actors.worldmodel.rules import RuleEngine
from mrss.actors.worldmodel.store import SqliteWorldStore, WorldStore, postgres_url_problem
from mrss.config.broker import table
from mrss.edge.http_token import (
    TOKEN_FILE_KEY,
    configured_token,
    exposure_problem,
)
from mrss.errors import ConfigError
from mrss.messages import DataRequest, Envelope, Percept
from mrss.options import Option
from mrss.runtime.busport import BusPort, bus_port
from mrss.runtime.component import Component, ComponentContext
from mrss.runtime.edge import edge_config
from mrss.runtime.operator_guard import OperatorGuard
from mrss.runtime.percept_channel import PerceptChannel
from mrss.textfile import write_whole
from mrss.world.access import WORLD_MODEL_URL_FILE
from mrss.world.topics import WM_REQUEST_TOPIC, wm_reply_topic

log = logging.getLogger("mrss.worldmodel")
URL_FILE = WORLD_MODEL_URL_FILE
PerceptSend = Callable[[Percept], object]


def recorded_port(run_dir: Path | None, host: str) -> int:
    """The port an earlier incarnation of this run served on (0: none recorded)."""
    if run_dir is None:
        return 0
    try:
        parts = urlsplit((run_dir / URL_FILE).read_text(encoding="utf-8").strip())
        port = parts.port
    except (OSError, ValueError):
        return 0
    return port if port and parts.hostname == host else 0


def serve_http(world: WorldModel, host: str, port: int, run_dir: Path | None, *,
               token: str | None = None, timeout: float = DEFAULT_TIMEOUT,
               operators: OperatorGuard | None = None) -> WorldModelHttp:
    """The HTTP API on `port`, or (0) on the port recorded by an earlier incarnation,
    or a free one; the URL is recorded in the run folder."""
    wanted = port or recorded_port(run_dir, host)
    try:
        http = WorldModelHttp(world, host, wanted, token=token, timeout=timeout,
                              operators=operators)
    except OSError as exc:
        if port or not wanted:
            raise
        log.warning("world model port %d is taken (%s); serving on a new one", wanted, exc)
        http = WorldModelHttp(world, host, 0, token=token, timeout=timeout,
                              operators=operators)
    if run_dir is not None:
        write_whole(run_dir / URL_FILE, http.url + "\n")
    return http


def http_settings(section: Mapping[str, Any], project_dir: Path | None
                  ) -> tuple[tuple[str, int] | None, str | None, float]:
    """((host, port) or None without HTTP, token, timeout); ConfigError naming the key,
    also when the API would be served beyond loopback without a token."""
    values = values_of(section)
    if not values.flag("http"):
        return None, None, DEFAULT_TIMEOUT
    host, port, timeout = values["http_host"], values.whole("http_port"), values["http_timeout"]
    if not host:
        raise ConfigError("must be a host name or address", key="worldmodel.http_host")
    token = configured_token(section, project_dir)
    problem = exposure_problem(host, token is not None)
    if problem:
        raise ConfigError(problem, key=f"worldmodel.{TOKEN_FILE_KEY}")
    return (host, port), token, float(timeout)


def open_store(run_dir: Path | None, section: Mapping[str, Any]) -> WorldStore:
    """The store the configuration names: PostGIS at `url`, else SQLite at `path`."""
    values = values_of(section)
    url = values.raw("url")  # judged below, with what a PostgreSQL URL looks like
    if url is None:
        return SqliteWorldStore(store_path(run_dir, section), durable=values.flag("durable"))
    text = url if isinstance(url, str) else repr(url)
    problem = postgres_url_problem(text)
    if problem:
        raise ConfigError(problem, key="worldmodel.url")
    from mrss.actors.worldmodel.postgis import PostgisWorldStore
    return PostgisWorldStore(text, batch_size=values.whole("batch_size"),
                             batch_interval=values.number("batch_interval"))


def store_path(run_dir: Path | None, section: Mapping[str, Any]) -> str:
    """Where the SQLite file goes: `path` under the run folder, or ':memory:'."""
    path = values_of(section).text("path")
    if not path:
        raise ConfigError("must be a file name or ':memory:'", key="worldmodel.path")
    if path == ":memory:" or run_dir is None:
        return ":memory:"
    return str(run_dir / path)


class WorldModelComponent(Component):
    """Component: the world model, its rules, its bus functions and its HTTP API."""

    #: The options this component reads (`mrss check` validates them; docs/config.md).
    SECTION: ClassVar[str] = "worldmodel"  # read from [worldmodel], under its own table's keys
    OPTIONS: ClassVar[tuple[Option, ...]] = WORLDMODEL_OPTIONS

    def __init__(self) -> None:
        self.world: WorldModel | None = None
        self.http: WorldModelHttp | None = None
        self._bus: BusPort | None = None
        self._percepts: PerceptChannel | None = None

    def start(self, ctx: ComponentContext) -> None:
        """Component entry: bus and percept channel from the context, then `run`."""
        config = edge_config(ctx, "worldmodel")
        http_settings(table(config, "worldmodel"), ctx.project_dir)  # refused before the bus
        bus = bus_port(ctx)
        self._percepts = PerceptChannel.for_component(ctx)
        self.run(ctx.project_dir, ctx.run_dir, config, bus, percepts=self._percepts.send)
        bus.wait_connected(5.0)  # ready means requests are heard

    def run(self, project_dir: Path | None, run_dir: Path | None, config: Mapping[str, Any],
            bus: BusPort, *, percepts: PerceptSend | None = None) -> None:
        """Open the store, load rules and seed, serve the bus and (optionally) HTTP.

        Rules' percepts go to `percepts` (default: published on `bus`).
        """
        section = table(config, "worldmodel")
        http, token, timeout = http_settings(section, project_dir)  # refused before anything
        rules = RuleEngine(load_rules(project_dir, section))
        self._bus = bus
        send: PerceptSend = percepts or bus.publish

        def emit(text: str) -> None:
            send(Percept(literal=text))

        self.world = WorldModel(open_store(run_dir, section), rules, emit)
        seeded = load_seed(self.world, project_dir, section)
        bus.subscribe([WM_REQUEST_TOPIC], self._on_request)
        if http is not None:
            self.http = serve_http(self.world, *http, run_dir, token=token,
                                   timeout=timeout, operators=OperatorGuard(project_dir, log))
            self.http.start()
        log.info("world model up: %s, %d rules, %d seeded objects, HTTP %s%s",
                 getattr(self.world.store, "where", type(self.world.store).__name__),
                 len(rules.rules), seeded, self.http.url if self.http else "off",
                 " (token required)" if self.http and self.http.token_required else "")

    def _on_request(self, env: Envelope) -> None:
        body = env.body
        if env.topic != WM_REQUEST_TOPIC or not isinstance(body, DataRequest):
            return
        assert self.world is not None and self._bus is not None
        self._bus.publish(self.world.handle(body), topic=wm_reply_topic(env.src))

    def stop(self) -> None:
        """Stop HTTP and the bus handlers, close the store."""
        if self.http is not None:
            self.http.stop()
        if self._bus is not None:
            self._bus.close()
        if self._percepts is not None:
            self._percepts.flush(1.0)
            self._percepts.close()
        if self.world is not None:
            self.world.store.close()
