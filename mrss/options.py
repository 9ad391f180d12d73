"""Declared options: the code that reads an option declares it, once, next to the reading.

A component class (or an edge table, adapter, data layer) lists what it reads from its
project.toml table as `OPTIONS: ClassVar[tuple[Option, ...]]`. The declaration is the
one source for the option's type, default, allowed values and documentation: `mrss
check` judges a table against it (unknown keys, wrong types, values that break the
option's `Check`) and the docs list it. A declaration may mix plain key names with
`Option`s; `option_names` gives the names of both.

The code reads its options through the same declaration (`Option.read`, or
`OptionValues` for a whole table), so each default is written once, in the declaration,
and an option nobody declared cannot be read.
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from enum import StrEnum
from typing import Any

from mrss.errors import ConfigError


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

    def read(self, table: Mapping[str, Any], *, section: str = "") -> Any:
        """This option's value in `table`, else its declared default (a fresh copy of a
        table or list). A value of the wrong type, outside `choices` or breaking a numeric
        `check` is a ConfigError naming `section.name` (`mrss check` judges the rest)."""
        value = table.get(self.name)
        if value is None:
            return copy.copy(self.default)
        problem = self.problem(value)
        if problem:
            raise ConfigError(problem, key=f"{section}.{self.name}" if section else self.name)
        return float(value) if self.kind is float else value

    def problem(self, value: Any) -> str | None:
        """What is wrong with `value` by this declaration's type, choices and numeric check."""
        kinds = self.kind if isinstance(self.kind, tuple) else (self.kind,)
        if not any(isinstance(value, k) and not (isinstance(value, bool) and k is not bool)
                   or (k is float and isinstance(value, int) and not isinstance(value, bool))
                   for k in kinds):
            return f"must be {' or '.join(_TYPE_NAMES.get(k, k.__name__) for k in kinds)}, " \
                   f"not {value!r}"
        if self.choices and value not in self.choices:
            return f"must be one of {', '.join(map(str, self.choices))}, not {value!r}"
        bound = _BOUNDS.get(self.check)
        if bound is not None and isinstance(value, int | float) and not bound[0](value):
            return f"must be {bound[1]}, not {value!r}"
        return None


_TYPE_NAMES = {str: "a string", int: "an integer", float: "a number", bool: "true or false",
               list: "a list", dict: "a table"}
_BOUNDS: dict[Check, tuple[Callable[[float], bool], str]] = {
    Check.POSITIVE: (lambda v: v > 0, "> 0"),
    Check.NON_NEGATIVE: (lambda v: v >= 0, ">= 0"),
    Check.PORT: (lambda v: 0 <= v <= 65535, "a port number (0 for a free one)"),
}


class OptionValues:
    """A table of project.toml read through its declaration: `values["name"]` is the
    option's value or its declared default; reading an undeclared name is a KeyError."""

    def __init__(self, declared: Iterable[str | Option], table: Mapping[str, Any], *,
                 section: str = "") -> None:
        self._declared = {o.name: o for o in declared if isinstance(o, Option)}
        self._table = table
        self._section = section

    def __getitem__(self, name: str) -> Any:
        return self._declared[name].read(self._table, section=self._section)

    def raw(self, name: str) -> Any:
        """The value as written (or the declared default), unchecked: for a value a richer
        rule judges right after (a URL that says what it should have been)."""
        option = self._declared[name]
        value = self._table.get(name)
        return copy.copy(option.default) if value is None else value

    def number(self, name: str) -> float:
        return float(self[name])

    def whole(self, name: str) -> int:
        return int(self[name])

    def flag(self, name: str) -> bool:
        return bool(self[name])

    def text(self, name: str) -> str:
        value = self[name]
        return "" if value is None else str(value)


def option_names(options: tuple[str | Option, ...]) -> tuple[str, ...]:
    """The key names of a declaration that may mix plain names and `Option`s."""
    return tuple(o.name if isinstance(o, Option) else o for o in options)
