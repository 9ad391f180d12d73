"""A project's own operator commands: `[operator.commands.NAME]` of project.toml.

Besides the fixed vocabulary of `[operator]` (area, cancel, priority, teleop, hold), a
project declares the commands its operator sends, each a form of typed fields and the
percept it becomes:

    [operator.commands.exclusion]
    label = "Exclusion zone: robots keep out"
    percept = "exclusion_zone(Zone, Shape)"  # fields by name, capitalised
    role = "commander"                       # the least role that may send it
    topic = "mrss/ui/exclusion"              # default "mrss/operator/<name>"
    fields = [
      { name = "zone", type = "text", atom = true, default = "z1" },
      { name = "shape", type = "polygon", max_vertices = 50 },
    ]

Field types (`FieldType`): point (`LAT,LON` -> `[Lat, Lon]`), polygon (`LAT,LON;
LAT,LON; ...` -> a list of points; not self-intersecting, at most `max_vertices`),
circle (`LAT,LON,RADIUS` -> `circle([Lat, Lon], Radius)`; `min`/`max` bound the radius),
number (`min`, `max`, `integer`), choice (`choices`; an atom), text (a string, or an
atom with `atom = true`). `units` and `label` are for the form.
The declarations are read by `mrss.config.operator_declarations`.

One check serves both ends: the dashboard's form (`values_from_text`, the operator's
text) and the events manager (`CommandSpec.literal`, any JSON on the topic, which it
checks again before the agent sees it). Nothing here knows Textual.
"""

from __future__ import annotations

import difflib
import json
from collections.abc import Mapping
from dataclasses import dataclass
from enum import StrEnum
from typing import Any

from mrss.agentspeak import parse_literal
from mrss.agentspeak.terms import Var

DEFAULT_MAX_VERTICES = 100
HARD_MAX_VERTICES = 1000  # no form, and no zone on the wire, has more


class FieldType(StrEnum):
    """What a command's field holds."""

    POINT = "point"
    POLYGON = "polygon"
    CIRCLE = "circle"
    NUMBER = "number"
    CHOICE = "choice"
    TEXT = "text"


HINTS = {FieldType.POINT: "LAT,LON", FieldType.POLYGON: "LAT,LON; LAT,LON; LAT,LON ...",
         FieldType.CIRCLE: "LAT,LON,RADIUS", FieldType.NUMBER: "a number",
         FieldType.CHOICE: "one of", FieldType.TEXT: "text"}


class CommandError(ValueError):
    """A command's value that cannot be sent; the text says what to fix, `field` where."""

    def __init__(self, message: str, field_name: str | None = None) -> None:
        super().__init__(message)
        self.field = field_name


@dataclass(frozen=True)
class FieldSpec:
    """One field of a command's form."""

    name: str
    type: FieldType
    label: str = ""
    units: str = ""
    default: Any = None
    minimum: float | None = None
    maximum: float | None = None
    integer: bool = False
    choices: tuple[str, ...] = ()
    atom: bool = False
    max_vertices: int = DEFAULT_MAX_VERTICES

    @property
    def variable(self) -> str:
        """The percept template's variable for this field: `shape` -> `Shape`."""
        return self.name[:1].upper() + self.name[1:]

    def hint(self) -> str:
        """What to type, for the form's label."""
        text = HINTS[self.type]
        if self.type is FieldType.CHOICE:
            text += " " + ", ".join(self.choices)
        bounds = _bounds(self.minimum, self.maximum)
        if bounds and self.type in (FieldType.NUMBER, FieldType.CIRCLE):
            text += f", {'radius ' if self.type is FieldType.CIRCLE else ''}{bounds}"
        if self.units:
            text += f" ({self.units})"
        if self.type is FieldType.POLYGON:
            text += f", at most {self.max_vertices} vertices"
        return text

    def default_text(self) -> str:
        """The default as the form shows it ("" : none)."""
        value = self.default
        if value is None:
            return ""
        if self.type is FieldType.POINT:
            return f"{value[0]},{value[1]}"
        if self.type is FieldType.CIRCLE:
            return f"{value[0]},{value[1]},{value[2]}"
        if self.type is FieldType.POLYGON:
            return "; ".join(f"{p[0]},{p[1]}" for p in value)
        if self.type is FieldType.NUMBER:
            return f"{value:g}"
        return str(value)

    # -- the operator's text -> the JSON value --------------------------------------------
    def from_text(self, text: str) -> Any:
        """The JSON value of the form's text; CommandError naming this field."""
        text = text.strip()
        if not text:
            raise CommandError(f"{self.name}: required ({self.hint()})", self.name)
        if self.type is FieldType.POINT:
            value: Any = _numbers(text, 2, self)
        elif self.type is FieldType.CIRCLE:
            lat, lon, radius = _numbers(text, 3, self)
            value = {"center": [lat, lon], "radius": radius}
        elif self.type is FieldType.POLYGON:
            parts = [p for p in text.replace("\n", ";").split(";") if p.strip()]
            if len(parts) > self.max_vertices:
                raise CommandError(f"{self.name}: {len(parts)} vertices, at most "
                                   f"{self.max_vertices}", self.name)
            value = [_numbers(p, 2, self) for p in parts]
        elif self.type is FieldType.NUMBER:
            value = _number(text, self)
        else:
            value = text
        return self.check(value)

    # -- any JSON value (the form's, or a client's on the topic) --------------------------
    def check(self, value: Any) -> Any:
        """The value, normalised, if it fits the field; CommandError otherwise."""
        kind = self.type
        if kind is FieldType.POINT:
            return _point(value, self)
        if kind is FieldType.CIRCLE:
            if not isinstance(value, Mapping) or set(value) != {"center", "radius"}:
                raise CommandError(f"{self.name}: a circle is {{\"center\": [lat, lon], "
                                   f"\"radius\": m}}", self.name)
            radius = _real(value["radius"], self, "radius")
            if radius <= 0:
                raise CommandError(f"{self.name}: radius must be more than 0", self.name)
            self._in_range(radius, "radius")
            return {"center": _point(value["center"], self), "radius": radius}
        if kind is FieldType.POLYGON:
            return _polygon(value, self)
        if kind is FieldType.NUMBER:
            number = _real(value, self, "value")
            if self.integer and number != int(number):
                raise CommandError(f"{self.name}: must be a whole number, not {number:g}",
                                   self.name)
            self._in_range(number, "value")
            return int(number) if self.integer else number
        if not isinstance(value, str) or not value.strip():
            raise CommandError(f"{self.name}: must be text", self.name)
        if kind is FieldType.CHOICE:
            if value not in self.choices:
                raise CommandError(f"{self.name}: {value!r} is not one of "
                                   f"{', '.join(self.choices)}{did_you_mean(value, self.choices)}",
                                   self.name)
            return value
        if self.atom and not identifier(value):
            raise CommandError(f"{self.name}: must be a lowercase identifier (z1, north), "
                               f"not {value!r}", self.name)
        return value

    def _in_range(self, number: float, what: str) -> None:
        low, high = self.minimum, self.maximum
        if (low is not None and number < low) or (high is not None and number > high):
            unit = f" {self.units}" if self.units else ""
            raise CommandError(f"{self.name}: {what} {number:g}{unit} is out of range "
                               f"({_bounds(low, high)})", self.name)

    # -- the JSON value -> an AgentSpeak term ---------------------------------------------
    def term(self, value: Any) -> str:
        kind = self.type
        if kind is FieldType.POINT:
            return _pair(value)
        if kind is FieldType.CIRCLE:
            return f"circle({_pair(value['center'])}, {_num(value['radius'])})"
        if kind is FieldType.POLYGON:
            return "[" + ", ".join(_pair(p) for p in value) + "]"
        if kind is FieldType.NUMBER:
            return _num(value)
        if kind is FieldType.CHOICE or self.atom:
            return value if identifier(value) else json.dumps(value)
        return json.dumps(value)


@dataclass(frozen=True)
class CommandSpec:
    """One declared command: its form's fields and the percept it becomes."""

    name: str
    percept: str
    fields: tuple[FieldSpec, ...]
    topic: str
    label: str = ""
    role: str = "operator"
    goal_field: str = ""  # the field naming the goal (the mission panel follows it)
    functor: str = ""
    arity: int = 0

    def field(self, name: str) -> FieldSpec:
        return next(f for f in self.fields if f.name == name)

    def values_from_text(self, texts: Mapping[str, str]) -> dict[str, Any]:
        """The payload of the form's texts; CommandError naming the first field at fault."""
        return {f.name: f.from_text(texts.get(f.name, "")) for f in self.fields}

    def checked(self, payload: Mapping[str, Any]) -> dict[str, Any]:
        """The payload if every field fits (extra keys but `id` refused); CommandError."""
        extra = sorted(set(payload) - {f.name for f in self.fields} - {"id"})
        if extra:
            hint = did_you_mean(extra[0], [f.name for f in self.fields])
            raise CommandError(f"unknown field {extra[0]!r}{hint}", extra[0])
        values = {}
        for spec in self.fields:
            if spec.name not in payload:
                raise CommandError(f"{spec.name}: required", spec.name)
            values[spec.name] = spec.check(payload[spec.name])
        return values

    def literal(self, payload: Mapping[str, Any]) -> str:
        """The percept the payload becomes (checked first): `exclusion_zone(z1, [[..]])`."""
        values = self.checked(payload)
        terms = {f.variable: f.term(values[f.name]) for f in self.fields}
        literal = parse_literal(self.percept)
        args = [terms[a.name] if isinstance(a, Var) else str(a) for a in literal.args]
        return f"{literal.functor}({', '.join(args)})" if args else literal.functor

    def goal_of(self, payload: Mapping[str, Any]) -> str:
        """The goal the payload names ("" : the command names none)."""
        return str(payload.get(self.goal_field, "")) if self.goal_field else ""

    def summary(self, payload: Mapping[str, Any]) -> str:
        """A short line for the operator: `exclusion zone=z1 shape=4 vertices`."""
        parts = []
        for spec in self.fields:
            value = payload.get(spec.name)
            if spec.type is FieldType.POLYGON and isinstance(value, list):
                parts.append(f"{spec.name}={len(value)} vertices")
            elif spec.type is FieldType.CIRCLE and isinstance(value, Mapping):
                parts.append(f"{spec.name}=r {value['radius']:g}")
            else:
                parts.append(f"{spec.name}={value}")
        return f"{self.name} " + " ".join(parts)


# -- values -----------------------------------------------------------------------------
def identifier(text: str) -> bool:
    return bool(text) and text[0].islower() and text.replace("_", "a").isalnum() \
        and text.isascii()


def did_you_mean(word: str, known: Any) -> str:
    close = difflib.get_close_matches(word, list(known), n=1)
    return f"; did you mean {close[0]!r}?" if close else ""


def _bounds(low: float | None, high: float | None) -> str:
    if low is not None and high is not None:
        return f"{low:g} to {high:g}"
    if low is not None:
        return f"at least {low:g}"
    if high is not None:
        return f"at most {high:g}"
    return ""


def _real(value: Any, spec: FieldSpec, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or value != value \
            or value in (float("inf"), float("-inf")):
        raise CommandError(f"{spec.name}: {what} must be a number, not {value!r}", spec.name)
    return float(value)


def _number(text: str, spec: FieldSpec) -> float:
    try:
        return float(text)
    except ValueError:
        raise CommandError(f"{spec.name}: {text!r} is not a number", spec.name) from None


def _numbers(text: str, count: int, spec: FieldSpec) -> list[float]:
    parts = [p for p in text.replace(" ", "").split(",") if p]
    if len(parts) != count:
        shape = HINTS[spec.type] if count == 3 else "LAT,LON"
        raise CommandError(f"{spec.name}: {text.strip()!r} is not {shape}", spec.name)
    return [_number(p, spec) for p in parts]


def _point(value: Any, spec: FieldSpec) -> list[float]:
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        raise CommandError(f"{spec.name}: a point is [lat, lon], not {value!r}", spec.name)
    lat, lon = _real(value[0], spec, "latitude"), _real(value[1], spec, "longitude")
    if not (-90 <= lat <= 90 and -180 <= lon <= 180):
        raise CommandError(f"{spec.name}: {lat:g},{lon:g} is not a position (latitude "
                           "-90..90, longitude -180..180)", spec.name)
    return [lat, lon]


def _polygon(value: Any, spec: FieldSpec) -> list[list[float]]:
    from shapely.geometry import Polygon  # only where a polygon is checked
    from shapely.validation import explain_validity

    if not isinstance(value, list):
        raise CommandError(f"{spec.name}: a polygon is a list of [lat, lon]", spec.name)
    if len(value) > spec.max_vertices:
        raise CommandError(f"{spec.name}: {len(value)} vertices, at most {spec.max_vertices}",
                           spec.name)
    points = [_point(p, spec) for p in value]
    if len(points) > 1 and points[0] == points[-1]:
        points = points[:-1]  # closed by repeating the first vertex: the same polygon
    if len(points) < 3:
        raise CommandError(f"{spec.name}: a polygon needs at least 3 vertices, not "
                           f"{len(points)}", spec.name)
    shape = Polygon([(lon, lat) for lat, lon in points])
    if not shape.is_valid:
        why = explain_validity(shape)
        what = "crosses itself" if "self-intersection" in why.lower() else why
        raise CommandError(f"{spec.name}: the polygon {what} (vertices in order around "
                           "its edge)", spec.name)
    if shape.area == 0:
        raise CommandError(f"{spec.name}: the polygon has no area", spec.name)
    return points


def _num(value: float) -> str:
    return repr(value) if isinstance(value, float) else str(value)


def _pair(point: list[float]) -> str:
    return f"[{_num(point[0])}, {_num(point[1])}]"
