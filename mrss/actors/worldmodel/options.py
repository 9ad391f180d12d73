"""The options of the world model (`[worldmodel]`, and its component's own table), declared
once: `mrss check` judges a table by them and the component reads through them."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from mrss.actors.worldmodel.http import DEFAULT_TIMEOUT
from mrss.actors.worldmodel.writebehind import DEFAULT_INTERVAL, DEFAULT_SIZE
from mrss.edge.http_token import TOKEN_ENV_KEY, TOKEN_FILE_KEY
from mrss.options import Check, Option, OptionValues

#: The options of [worldmodel] (and the component's own table), declared once.
WORLDMODEL_OPTIONS: tuple[Option, ...] = (
    Option("path", str, "worldmodel.sqlite",
           "database file in the run folder, or \":memory:\" (without url)"),
    Option("url", str, None, "postgresql://user@host:port/db: keep the objects in "
           "PostGIS instead of the embedded SQLite file", Check.POSTGRES_URL),
    Option("durable", bool, False, "SQLite: sync every write to disk (survives a power "
           "cut; several times fewer writes per second)"),
    Option("batch_size", int, DEFAULT_SIZE, "PostGIS: telemetry updates (writes nobody "
           "waits for) committed together in one transaction (1: one transaction each)",
           Check.POSITIVE),
    Option("batch_interval", float, DEFAULT_INTERVAL, "PostGIS: seconds a telemetry update "
           "may wait for its batch's commit (lost if the world model is killed meanwhile)",
           Check.POSITIVE),
    Option("seed", str, None, "objects to load at start (JSON)", Check.PROJECT_FILE),
    Option("rules", list, [], "built-in rules: [[worldmodel.rules]] tables"),
    Option("rules_module", str, "worldmodel.py", "defines rules(options) -> list[Rule]"),
    Option("http", bool, True, "serve the HTTP API"),
    Option("http_host", str, "127.0.0.1", "address of the HTTP API"),
    Option("http_port", int, 0, "port of the HTTP API (0: a free one, kept across restarts)",
           Check.PORT),
    Option("http_timeout", float, DEFAULT_TIMEOUT,
           "seconds a connection may take to send a request before it is dropped",
           Check.POSITIVE),
    Option(TOKEN_FILE_KEY, str, None, "file (in the project) holding the HTTP API's "
           "bearer token; required when http_host is not loopback", Check.TOKEN_FILE),
    Option(TOKEN_ENV_KEY, str, None, "environment variable holding the bearer token "
           "(instead of token_file)"),
)


def values_of(section: Mapping[str, Any]) -> OptionValues:
    """[worldmodel] (with the component's own keys over it) read through the declaration."""
    return OptionValues(WORLDMODEL_OPTIONS, section, section="worldmodel")
