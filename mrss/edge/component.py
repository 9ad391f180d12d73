"""What the edge components share: their bus port, their configuration, the broker URL.

A component gets a `mrss.supervision.component.ComponentContext`. Its configuration is
the project's top-level tables (`[broker]`, `[events]`, `[datalayer]`, `[worldmodel]`
of project.toml) with the component's own free keys (`ctx.options`, from
`[components.<id>]`) laid over its table, so either place works.

The broker URL is `[broker] url` when set; otherwise the one the embedded broker
component wrote to `<run_dir>/broker.url` (it starts first, so the file is there).
"""

from __future__ import annotations

import os
import threading
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any
from urllib.parse import quote, urlsplit, urlunsplit

from mrss.bus import BusEndpoints, Subscriber
from mrss.config import load_file
from mrss.edge.busport import EnvelopeCallback, MessagePublisher, Subscription
from mrss.errors import ConfigError
from mrss.messages import Message
from mrss.projects import PROJECT_FILE
from mrss.supervision.component import ComponentContext

BROKER_URL_FILE = "broker.url"
EDGE_SECTIONS = ("broker", "events", "datalayer", "worldmodel")


def table(config: Mapping[str, Any], name: str) -> Mapping[str, Any]:
    """The `[name]` table of a project configuration ({} when absent)."""
    value = config.get(name, {})
    if not isinstance(value, Mapping):
        raise ConfigError(f"[{name}] must be a table", key=name)
    return value


def edge_config(ctx: ComponentContext, own_section: str) -> dict[str, Any]:
    """The edge tables of the project's configuration, `ctx.options` over `own_section`."""
    sections: dict[str, Any] = {}
    project_file = ctx.project_dir / PROJECT_FILE
    if project_file.is_file():
        sections = load_file(project_file).sections
    config = {name: dict(table(sections, name)) for name in EDGE_SECTIONS}
    config[own_section].update(ctx.options)
    return config


def resolved_broker_url(config: Mapping[str, Any], run_dir: Path | None) -> str | None:
    """The broker every adapter and link uses: configured, or the embedded one's, or None."""
    url = table(config, "broker").get("url")
    if url:
        return str(url)
    if run_dir is not None:
        path = run_dir / BROKER_URL_FILE
        if path.is_file():
            return path.read_text(encoding="utf-8").strip() or None
    return None


def with_login(url: str, broker: Mapping[str, Any]) -> str:
    """`url` with the project's MQTT login (`[broker] username`, `password` or
    `password_env`) when it carries none; ConfigError when password_env is not set."""
    user = broker.get("username")
    parts = urlsplit(url)
    if not isinstance(user, str) or not user or parts.username:
        return url
    password = broker.get("password")
    env = broker.get("password_env")
    if isinstance(env, str) and env:
        if env not in os.environ:
            raise ConfigError(f"environment variable {env!r} is not set",
                              key="broker.password_env")
        password = os.environ[env]
    login = quote(user, safe="")
    if isinstance(password, str) and password:
        login += ":" + quote(password, safe="")
    return urlunsplit((parts.scheme, f"{login}@{parts.netloc}", parts.path, parts.query,
                       parts.fragment))


def with_broker(config: Mapping[str, Any], run_dir: Path | None) -> dict[str, Any]:
    """A copy of `config` whose `[broker] url` is the resolved one (when there is one)."""
    out = dict(config)
    url = resolved_broker_url(config, run_dir)
    if url:
        out["broker"] = {**table(config, "broker"), "url": url}
    return out


class ZmqBusPort:
    """A BusPort over `mrss.bus`: a Publisher, and one Subscriber per subscription."""

    def __init__(self, endpoints: BusEndpoints, publisher: MessagePublisher, name: str) -> None:
        self._endpoints = endpoints
        self._publisher = publisher
        self._name = name
        self._subs: list[Subscriber] = []
        self._lock = threading.Lock()

    @property
    def src(self) -> str:
        """The name this port's messages go out under (its Publisher's `src`)."""
        return str(getattr(self._publisher, "src", self._name))

    def publish(self, msg: Message, topic: str | None = None) -> str:
        return self._publisher.publish(msg, topic)

    def subscribe(self, prefixes: Sequence[str], callback: EnvelopeCallback,
                  ) -> Subscription:
        sub = Subscriber(self._endpoints, prefixes=list(prefixes),
                         name=f"{self._name}:{','.join(prefixes)}")
        sub.start(callback)
        with self._lock:
            self._subs.append(sub)
        return sub

    def wait_connected(self, timeout: float = 5.0) -> bool:
        """Whether every subscription has been greeted by the proxy."""
        with self._lock:
            subs = list(self._subs)
        return all(sub.wait_connected(timeout) for sub in subs)

    def close(self) -> None:
        with self._lock:
            subs, self._subs = self._subs, []
        for sub in subs:
            sub.close()


def bus_port(ctx: ComponentContext) -> ZmqBusPort:
    """The component's view of the bus: its Publisher and the endpoints in its context."""
    return ZmqBusPort(BusEndpoints.from_dict(ctx.bus), ctx.publisher, ctx.name)
