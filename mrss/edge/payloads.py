"""Decode outside payloads (JSON over MQTT) and map them to AgentSpeak literals by schema.

A project adapter declares what it expects and gets a literal or a `PayloadError` that
names the topic and the reason; it never writes parsing code for the common case:

    AREA = JsonMapping("area_goal_received", Field("area", "atom"), Field("priority", "int"))
    AREA.literal(payload_bytes, topic="ui/area")  -> 'area_goal_received(a1,3)'

Field kinds: `atom` (must be a lowercase identifier), `robot` (an atom naming one of the
project's robots: given the robots, `args(obj, robots=...)` refuses any other, so a
message about a robot that does not exist is refused at the door), `symbol` (atom if it
can be, else a string), `string`, `int`, `number`, `lat`, `lon`, `bool`, `list` (of
scalars or lists), `term` (any JSON scalar or list), or a callable that converts the
value and raises ValueError for bad input. A field name may be a dotted path into
nested objects.

Every value is also held to the bounds of plain data (`mrss.edge.record_declarations`,
checked by `mrss.edge.validation`): strings of at most MAX_TEXT characters, integers
within +-2**53, finite numbers, lists of at most MAX_ITEMS items nested at most
MAX_DEPTH deep.
"""

from __future__ import annotations

import difflib
import json
import math
import re
from collections.abc import Callable, Collection
from dataclasses import dataclass
from typing import Any, Final

from mrss.agentspeak.literals import (
    RESERVED,
    Atom,
    PredicateError,
    Term,
    is_atom_name,
    literal,
    symbol,
)
from mrss.edge import record_declarations, validation
from mrss.errors import DecodeError


class PayloadError(DecodeError):
    """An outside payload is not what its schema says (not JSON, wrong fields, ...)."""


class _Required:
    def __repr__(self) -> str:
        return "REQUIRED"


REQUIRED: Final = _Required()
MAX_PAYLOAD = 1 << 20
_SURROGATE_ESCAPE = re.compile(r"\\u[dD][89a-fA-F]")  # \ud800 to \udfff


def _reject_constant(name: str) -> Any:
    raise ValueError(f"{name} is not a JSON number")


def _lone_surrogate(value: Any) -> str | None:
    """The first string of `value` (keys too) that is not Unicode text, or None."""
    stack = [value]
    while stack:
        item = stack.pop()
        if isinstance(item, str):
            try:
                item.encode("utf-8")
            except UnicodeEncodeError:
                return item
        elif isinstance(item, list):
            stack.extend(item)
        elif isinstance(item, dict):
            stack.extend(item.keys())
            stack.extend(item.values())
    return None


def decode_json(payload: bytes, *, topic: str | None = None) -> Any:
    """Parse a UTF-8 JSON payload (NaN/Infinity refused); PayloadError otherwise.

    JSON may escape a lone UTF-16 surrogate ("\\ud800"), which is no Unicode text: no
    log line, bus message or database can hold it, so such a payload is refused here
    like any other that does not parse.
    """
    if len(payload) > MAX_PAYLOAD:
        raise PayloadError(f"payload of {len(payload)} bytes exceeds {MAX_PAYLOAD}", topic=topic)
    try:
        text = payload.decode("utf-8")
    except UnicodeDecodeError:
        raise PayloadError("payload is not UTF-8", topic=topic) from None
    try:
        value = json.loads(text, parse_constant=_reject_constant)
    except (ValueError, RecursionError) as exc:
        raise PayloadError(f"payload is not JSON: {exc}", topic=topic) from None
    if _SURROGATE_ESCAPE.search(text):  # only an escape can make one: skip the walk
        bad = _lone_surrogate(value)
        if bad is not None:
            shown = bad.encode("utf-8", "backslashreplace").decode("ascii", "replace")
            raise PayloadError(f"payload is not Unicode text: a lone surrogate in "
                               f"\"{shown[:40]}\"", topic=topic)
    return value


def decode_json_object(payload: bytes, *, topic: str | None = None) -> dict[str, Any]:
    """Parse a payload that must be a JSON object."""
    value = decode_json(payload, topic=topic)
    if not isinstance(value, dict):
        raise PayloadError(f"payload is a JSON {type(value).__name__}, not an object",
                           topic=topic)
    return value


def _as_str(value: Any) -> str:
    if not isinstance(value, str):
        raise ValueError(f"expected a string, got {type(value).__name__}")
    return validation.text(value, "string")


def _as_int(value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise ValueError(f"expected an integer, got {type(value).__name__}")
    return validation.integer(value, "integer")


def _as_number(value: Any) -> int | float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f"expected a number, got {type(value).__name__}")
    if isinstance(value, float) and not math.isfinite(value):
        raise ValueError("number is not finite")
    return validation.number(value, "number")


def _ranged(low: float, high: float) -> Callable[[Any], Term]:
    def convert(value: Any) -> Term:
        number = _as_number(value)
        if not low <= number <= high:
            raise ValueError(f"{number} is outside [{low}, {high}]")
        return number
    return convert


def _as_bool(value: Any) -> bool:
    if not isinstance(value, bool):
        raise ValueError(f"expected true or false, got {type(value).__name__}")
    return value


def _as_atom(value: Any) -> Atom:
    text = _as_str(value)
    if not is_atom_name(text):
        if text in RESERVED:
            raise ValueError(f"{text!r} is a reserved word of AgentSpeak, not an atom "
                             "(a 'string' or 'symbol' field takes it)")
        raise ValueError(f"{text!r} is not a lowercase identifier")
    return Atom(text)


def json_term(value: Any, depth: int = 0) -> Term:
    """A JSON scalar or list as a term: strings stay strings; objects and null are refused."""
    if isinstance(value, bool):
        return value
    if isinstance(value, str):
        return _as_str(value)
    if isinstance(value, (int, float)):
        return _as_number(value)
    if isinstance(value, list):
        if depth >= record_declarations.MAX_DEPTH:
            raise ValueError(f"list nested more than {record_declarations.MAX_DEPTH} deep")
        if len(value) > record_declarations.MAX_ITEMS:
            raise ValueError(f"list of {len(value)} items > {record_declarations.MAX_ITEMS}")
        return [json_term(v, depth + 1) for v in value]
    raise ValueError(f"a JSON {type(value).__name__} has no term form")


def _as_list(value: Any) -> Term:
    if not isinstance(value, list):
        raise ValueError(f"expected a list, got {type(value).__name__}")
    return json_term(value)


CONVERTERS: dict[str, Callable[[Any], Term]] = {
    "atom": _as_atom,
    "robot": _as_atom,  # and one of the robots, when they are given (Field.extract)
    "symbol": lambda v: symbol(_as_str(v)),
    "string": _as_str,
    "int": _as_int,
    "number": _as_number,
    "lat": _ranged(-90.0, 90.0),
    "lon": _ranged(-180.0, 180.0),
    "bool": _as_bool,
    "list": _as_list,
    "term": json_term,
}


@dataclass(frozen=True)
class Field:
    """One argument of a mapped literal: where it is in the payload and what it must be."""

    name: str
    kind: str | Callable[[Any], Term] = "symbol"
    default: Any = REQUIRED

    def __post_init__(self) -> None:
        if isinstance(self.kind, str) and self.kind not in CONVERTERS:
            close = difflib.get_close_matches(self.kind, list(CONVERTERS), n=1)
            hint = f"did you mean {close[0]!r}? " if close else ""
            raise ValueError(f"field {self.name!r}: unknown kind {self.kind!r}; {hint}"
                             f"known: {', '.join(CONVERTERS)}")

    def extract(self, obj: dict[str, Any], robots: Collection[str] | None = None) -> Term:
        """The converted value of this field in `obj`; ValueError names the field. A
        `robot` field's value must be one of `robots` (None: any atom)."""
        value: Any = obj
        for part in self.name.split("."):
            if not isinstance(value, dict) or part not in value:
                if self.default is REQUIRED:
                    raise ValueError(f"missing field {self.name!r}")
                return self.default  # type: ignore[no-any-return]
            value = value[part]
        convert = CONVERTERS[self.kind] if isinstance(self.kind, str) else self.kind
        try:
            term = convert(value)
        except (ValueError, TypeError, PredicateError) as exc:
            raise ValueError(f"field {self.name!r}: {exc}") from None
        if self.kind == "robot" and robots is not None and str(term) not in robots:
            known = ", ".join(sorted(robots)[:20]) or "none"
            raise ValueError(f"field {self.name!r}: unknown robot {str(term)!r} "
                             f"(known: {known})")
        return term


class JsonMapping:
    """A declared JSON payload shape and the literal `functor(fields...)` it becomes."""

    def __init__(self, functor: str, *fields: Field, annotations: tuple[Term, ...] = ()) -> None:
        if not is_atom_name(functor.removeprefix("~")):
            raise PredicateError(f"functor {functor!r} is not a valid atom")
        self.functor = functor
        self.fields = fields
        self.annotations = annotations

    def args(self, obj: dict[str, Any], *, topic: str | None = None,
             robots: Collection[str] | None = None) -> list[Term]:
        """The converted field values of a decoded payload object (`robot` fields among
        `robots`, when given: an adapter passes `self.robots`)."""
        try:
            return [f.extract(obj, robots) for f in self.fields]
        except ValueError as exc:
            raise PayloadError(str(exc), topic=topic) from None

    def literal(self, payload: bytes, *, topic: str | None = None,
                robots: Collection[str] | None = None) -> str:
        """The literal for a raw payload; PayloadError for anything that does not fit."""
        obj = decode_json_object(payload, topic=topic)
        try:
            return literal(self.functor, *self.args(obj, topic=topic, robots=robots),
                           annotations=self.annotations)
        except PredicateError as exc:
            raise PayloadError(str(exc), topic=topic) from None
