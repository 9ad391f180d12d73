"""Where the project's MQTT broker is, and how to log in to it: the `[broker]` table.

The broker URL is `[broker] url` when set; otherwise the one the embedded broker
component wrote to `<run_dir>/broker.url` (it starts first, so the file is there).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any
from urllib.parse import quote, urlsplit, urlunsplit

from mrss.errors import ConfigError

BROKER_URL_FILE = "broker.url"


def table(config: Mapping[str, Any], name: str) -> Mapping[str, Any]:
    """The `[name]` table of a project configuration ({} when absent)."""
    value = config.get(name, {})
    if not isinstance(value, Mapping):
        raise ConfigError(f"[{name}] must be a table", key=name)
    return value


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
