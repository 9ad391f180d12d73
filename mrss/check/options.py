"""Options of components and edge tables: every key declared, of its type, with a valid value.

Rules:
- the code that reads an option declares it (`OPTIONS` of `mrss.options.Option`s on the
  component class; a component that reads a table of its own names it in `SECTION`, and
  the project class it runs — adapter, data layer — adds its own `OPTIONS`);
- a key nobody declares is an error, with "did you mean" among the declared keys (and the
  supervision keys of a component table, `shutdown`, `restart`, ...);
- a value of the wrong type, or that breaks its `Check` (a URL that does not parse, a
  port that is not a number, a file the project folder lacks), is an error at its line;
- a value outside an option's `choices` is an error ("did you mean");
- a component class that declares no `OPTIONS` (a project's own component) is not checked,
  but a key of its table close to a supervision key (`restarts`) is a warning;
- a top-level table no layer owns is an error ("did you mean"); `[bus]`, `[broker]`
  (with `[broker.embedded]`) and `[logs]` are checked against `BUS_OPTIONS`,
  `BROKER_OPTIONS` and `LOG_OPTIONS`.
"""

from __future__ import annotations

import difflib
import math
import re
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

from mrss.actors.broker.passwords import password_file_problem
from mrss.actors.broker.service import BROKER_EMBEDDED_OPTIONS, BROKER_OPTIONS
from mrss.actors.worldmodel.store import postgres_url_problem
from mrss.bus.settings import BUS_OPTIONS
from mrss.check.findings import Report, did_you_mean
from mrss.check.toml_lines import key_line
from mrss.config.loader import COMPONENT_KEYS, OTHER_SECTIONS
from mrss.config.project import ProjectConfig
from mrss.edge.http_token import token_file_problem
from mrss.links.mavlink_signing import key_problem
from mrss.logfile import LOG_OPTIONS
from mrss.options import Check, Option

MAVLINK_URL = re.compile(r"^(udpin|udpout|udp|udpbcast|tcp|tcpin):([^:]+):(.+)$")


def declared_options(*classes: type | None) -> list[Option]:
    """Every `OPTIONS` entry of the classes and their bases, the subclass's first."""
    found: dict[str, Option] = {}
    for cls in classes:
        for klass in getattr(cls, "__mro__", ()):
            for option in vars(klass).get("OPTIONS", ()):
                found.setdefault(option.name, option)
    return list(found.values())


def check_values(config: ProjectConfig, report: Report, values: Mapping[str, Any],
                 declared: Sequence[Option], key_of: Any, *, owner: str,
                 ignore: Iterable[str] = (), hints: Iterable[str] = (),
                 undeclaring: type | None = None) -> None:
    """Findings for unknown keys and bad values; `key_of(name)` is the dotted key.

    `undeclaring`: a project class that declares no `OPTIONS` (written before options
    were declared): an unknown key may be one it reads, so it is a warning that shows the
    declaration to add, not an error."""
    by_name = {o.name: o for o in declared}
    skip = set(ignore)
    for name, value in values.items():
        if name in skip:
            continue
        key = key_of(name)
        line = key_line(config, key)
        option = by_name.get(name)
        if option is None:
            hint = did_you_mean(name, by_name, what="it reads", also=hints)
            if undeclaring is not None and "did you mean" not in hint:
                report.warning(str(config.file), f"{name} is not declared: if "
                               f"{undeclaring.__name__} reads it, add to the class: "
                               f"{declaration(name, value)}", line=line, check="options",
                               key=key)
            else:
                report.error(str(config.file), f"unknown option of {owner}" + hint,
                             line=line, check="options", key=key)
            continue
        problem = value_problem(option, value, config.directory)
        if problem:
            report.error(str(config.file), f"{problem} ({option.doc})" if option.doc
                         else problem, line=line, check="options", key=key)


def declaration(name: str, value: Any) -> str:
    """The one-line `OPTIONS` declaration of a key with this value."""
    kind = next((k for k in (bool, int, float, str, list, dict) if type(value) is k), None)
    default = repr(value) if kind in (bool, int, float, str) else "None"
    return (f"OPTIONS = (Option({name!r}, {kind.__name__ if kind else 'object'}, {default}, "
            f'"what it does"),)  # from mrss.api import Option')


def value_problem(option: Option, value: Any, project_dir: Path) -> str | None:
    """What is wrong with `value` for `option`, or None."""
    kinds = option.kind if isinstance(option.kind, tuple) else (option.kind,)
    ok = any(isinstance(value, k) and not (isinstance(value, bool) and k is not bool)
             for k in kinds) or (float in kinds and isinstance(value, int)
                                 and not isinstance(value, bool))
    if not ok:
        names = " or ".join(_type_name(k) for k in kinds)
        return f"expected {names}, not {value!r}"
    if option.choices and value not in option.choices:
        listing = " or ".join(repr(c) for c in option.choices)
        close = difflib.get_close_matches(value, [str(c) for c in option.choices], n=1,
                                          cutoff=0.6) if isinstance(value, str) else []
        return f"expected {listing}, not {value!r}" + (
            f"; did you mean {close[0]!r}?" if close else "")
    return check_problem(option.check, value, project_dir)


def check_problem(check: Check, value: Any, project_dir: Path) -> str | None:
    """What is wrong with a value of the right type for its `Check`, or None."""
    if check in (Check.POSITIVE, Check.NON_NEGATIVE, Check.PORT) and \
            isinstance(value, int | float) and not isinstance(value, bool):
        if check is Check.POSITIVE and not value > 0:
            return f"expected a number > 0, not {value!r}"
        if check is Check.NON_NEGATIVE and not value >= 0:
            return f"expected a number >= 0, not {value!r}"
        if check is Check.PORT and not (isinstance(value, int) and 0 <= value <= 65535):
            return f"expected a port number 0..65535, not {value!r}"
    if check is Check.URL and isinstance(value, str):
        return url_problem(value)
    if check is Check.MAVLINK_URL and isinstance(value, str):
        return mavlink_url_problem(value)
    if check is Check.POSTGRES_URL and isinstance(value, str):
        return postgres_url_problem(value)
    if check is Check.PROJECT_FILE and isinstance(value, str) \
            and not (project_dir / value).is_file():
        return f"no file {value!r} in the project folder"
    if check is Check.SIGNING_KEY and isinstance(value, str):
        return key_problem(project_dir / value, value)
    if check is Check.PASSWORD_FILE and isinstance(value, str):
        return password_file_problem(project_dir / value, value)
    if check is Check.TOKEN_FILE and isinstance(value, str):
        return token_file_problem(project_dir / value, value)
    if check is Check.POSITION and isinstance(value, list) and (
            len(value) not in (2, 3) or not all(isinstance(v, int | float)
                                                and not isinstance(v, bool) for v in value)):
        return f"expected [lat, lon] or [lat, lon, alt] (numbers), not {value!r}"
    if check is Check.RANGE and isinstance(value, list) and not _is_range(value):
        return f"expected [low, high] (finite numbers, low <= high), not {value!r}"
    return None


def _is_range(value: list[Any]) -> bool:
    return (len(value) == 2 and all(isinstance(v, int | float) and not isinstance(v, bool)
                                    and math.isfinite(v) for v in value)
            and value[0] <= value[1])


def url_problem(value: str) -> str | None:
    """Why `value` is not a `scheme://host[:port]` URL, or None."""
    try:
        parts = urlsplit(value)
        port = parts.port
    except ValueError as exc:
        return f"not a valid URL {value!r}: {exc} (expected scheme://host:port)"
    if not parts.scheme or not parts.hostname:
        return f"not a valid URL {value!r} (expected scheme://host:port)"
    del port
    return None


def mavlink_url_problem(value: str) -> str | None:
    """Why `value` is not a MAVLink connection string `udpin:HOST:PORT`, or None."""
    match = MAVLINK_URL.match(value)
    if not match:
        return (f"not a MAVLink URL {value!r} (expected udpin:HOST:PORT, udpout:HOST:PORT "
                "or tcp:HOST:PORT)")
    port = match.group(3)
    if not port.isdigit() or not 0 < int(port) < 65536:
        return f"port {port!r} of {value!r} is not a port number 1..65535"
    return None


def check_tables(config: ProjectConfig, report: Report) -> None:
    """A top-level table no layer owns is an error; `[bus]` and `[broker]` keys checked."""
    for name in config.sections:
        if name not in OTHER_SECTIONS:
            report.error(str(config.file), f"unknown table [{name}]"
                         + did_you_mean(name, OTHER_SECTIONS, what="known tables"),
                         line=key_line(config, name), check="options", key=name)
    for name, declared in (("bus", BUS_OPTIONS), ("broker", BROKER_OPTIONS),
                           ("broker.embedded", BROKER_EMBEDDED_OPTIONS), ("logs", LOG_OPTIONS)):
        table: Any = config.sections
        for part in name.split("."):
            table = table.get(part, {}) if isinstance(table, Mapping) else {}
        if not isinstance(table, Mapping):
            continue  # the enclosing table's check says it must be a table
        check_values(config, report, table, declared, lambda n, t=name: f"{t}.{n}",
                     owner=f"[{name}]")


def check_component(config: ProjectConfig, report: Report, comp_id: str, cls: type,
                    options: Mapping[str, Any], ignore: Iterable[str] = ()) -> None:
    """The free keys of `[components.<id>]` against the class's OPTIONS (if it declares them)."""
    if "OPTIONS" not in {k for c in cls.__mro__ for k in vars(c)}:
        for name in options:
            hint = did_you_mean(name, (), also=COMPONENT_KEYS)
            if name not in COMPONENT_KEYS and "did you mean" in hint:
                key = f"components.{comp_id}.{name}"
                report.warning(str(config.file), f"{name} is passed to {cls.__name__} as an "
                               f"option (it declares no OPTIONS){hint}",
                               line=key_line(config, key), check="options", key=key)
        return
    section = getattr(cls, "SECTION", None)
    declared = declared_options(cls)
    if section:  # its keys are checked with the section's, where the project class is known
        return
    check_values(config, report, options, declared, lambda n: f"components.{comp_id}.{n}",
                 owner=f"{cls.__name__} (components.{comp_id})", ignore=ignore,
                 hints=COMPONENT_KEYS)


def _type_name(kind: type) -> str:
    return {str: "a string", int: "an integer", float: "a number", bool: "true or false",
            list: "a list", dict: "a table"}.get(kind, kind.__name__)
