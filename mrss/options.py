"""Declared options: the code that reads an option declares it, once, next to the reading.

A component class (or an edge table, adapter, data layer) lists what it reads from its
project.toml table as `OPTIONS: ClassVar[tuple[Option, ...]]`. The declaration is the
one source for the option's type, default, allowed values and documentation: `mrss
check` judges a table against it (unknown keys, wrong types, values that break the
option's `Check`) and the docs list it. A declaration may mix plain key names with
`Option`s; `option_names` gives the names of both.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum
from typing import Any


class Check(StrEnum):
    """What an option's value must be beyond its type (validated by `mrss check`)."""

    NONE = "none"
    POSITIVE = "positive"  # a number > 0
    NON_NEGATIVE = "non_negative"  # a number >= 0
    PORT = "port"  # 0 (a free port) .. 65535
    URL = "url"  # scheme://host[:port][/path], the port a number
    MAVLINK_URL = "mavlink_url"  # udpin:HOST:PORT, udpout:HOST:PORT, tcp:HOST:PORT, ...
    POSTGRES_URL = "postgres_url"  # postgresql://user@host:port/database
    PROJECT_FILE = "project_file"  # a file that exists in the project folder
    POSITION = "position"  # [lat, lon] or [lat, lon, alt], numbers
    RANGE = "range"  # [low, high], finite numbers, low <= high
    SIGNING_KEY = "signing_key"  # a MAVLink signing key file (64 hex chars) in the project
    PASSWORD_FILE = "password_file"  # an MQTT password file (mrss.actors.broker.passwords)
    TOKEN_FILE = "token_file"  # an HTTP bearer token file in the project (mrss.edge.http_token)


@dataclass(frozen=True)
class Option:
    """One option a component (or an edge table, adapter, data layer) reads: declared once,
    by the code that reads it, as `OPTIONS: ClassVar[tuple[Option, ...]]` on its class.

    `kind` is the type (a tuple for several; float accepts int), `default` the value used
    when it is absent, `doc` one line for docs and `mrss check`, `check` a value rule,
    `choices` the values allowed (a closed set; empty: any).
    """

    name: str
    kind: type | tuple[type, ...]
    default: Any = None
    doc: str = ""
    check: Check = Check.NONE
    choices: tuple[Any, ...] = ()


def option_names(options: tuple[str | Option, ...]) -> tuple[str, ...]:
    """The key names of a declaration that may mix plain names and `Option`s."""
    return tuple(o.name if isinstance(o, Option) else o for o in options)
