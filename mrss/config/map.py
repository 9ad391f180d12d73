"""How the dashboard's map draws a project's world-model objects: the `[map]` table of
project.toml. Without it (or for a kind it does not name) the map draws as it always
did: hotspots ✹ red, water sources ≈ blue, bases ⌂ green, other points by their
kind's initial, shapes as yellow outlines.

    [map]
    hide = ["robot"]                 # kinds not drawn at all

    [map.kinds.hotspot]              # one table per world-model kind
    glyph = "✹"                      # the one character of a point
    style = "bold red"               # a Rich style: of the glyph, or of a shape's lines
    state_field = "state"            # the attribute whose value picks a style below
    label = true                     # the object's id next to it (default true)

    [map.kinds.hotspot.states]       # state value -> style (others keep `style`)
    new = "bold red"
    supplying = "bold yellow"
    supplied = "green"

    [map.kinds.no_go]
    style = "bold red"
    polygon = "fill"                 # "outline" (default) or "fill" (dotted all over)

    [map.kinds.base]
    radius_field = "comm_radius_m"   # an attribute in metres: a ring around the point
    radius_style = "dim cyan"        # (the default)

`mrss check` validates the table (`mrss.check.map`). Nothing here knows Textual.
"""

from __future__ import annotations

import difflib
from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any

from rich.cells import cell_len
from rich.errors import StyleSyntaxError
from rich.style import Style

from mrss.errors import ConfigError

SECTION = "map"
DEFAULT_STYLE = "bold"  # a point of a kind without a default glyph
AREA_STYLE = "yellow"  # lines of a kind without a style
RING_STYLE = "dim cyan"  # a ring of `radius_field` without a `radius_style`
# glyph and style of the kinds drawn without any [map] table
DEFAULT_KINDS: dict[str, tuple[str, str]] = {
    "hotspot": ("✹", "bold red"), "water_source": ("≈", "bold blue"),
    "base": ("⌂", "bold green"), "robot": ("○", "dim")}


class PolygonDraw(StrEnum):
    """How a kind's shapes are drawn."""

    OUTLINE = "outline"
    FILL = "fill"


class KindKey(StrEnum):
    """The keys of a `[map.kinds.<kind>]` table."""

    GLYPH = "glyph"
    STYLE = "style"
    STATE_FIELD = "state_field"
    STATES = "states"
    POLYGON = "polygon"
    LABEL = "label"
    RADIUS_FIELD = "radius_field"
    RADIUS_STYLE = "radius_style"


@dataclass(frozen=True)
class KindStyle:
    """How one kind is drawn; None: the default."""

    glyph: str | None = None
    style: str | None = None
    state_field: str = ""
    states: dict[str, str] = field(default_factory=dict)
    polygon: PolygonDraw = PolygonDraw.OUTLINE
    label: bool = True
    radius_field: str = ""  # an attribute in metres: a ring that far around the point
    radius_style: str = RING_STYLE


@dataclass(frozen=True)
class MapConfig:
    """The kinds a project styles, and those it hides."""

    kinds: dict[str, KindStyle] = field(default_factory=dict)
    hide: frozenset[str] = frozenset()

    def kind(self, kind: str) -> KindStyle:
        return self.kinds.get(kind) or KindStyle()

    def point_look(self, kind: str, attributes: Mapping[str, Any]) -> tuple[str, str]:
        """(glyph, style) of a point object of `kind` with these attributes."""
        default_glyph, default_style = DEFAULT_KINDS.get(kind, ((kind or "?")[0],
                                                                DEFAULT_STYLE))
        look = self.kind(kind)
        return look.glyph or default_glyph, self._styled(look, attributes, default_style)

    def ring(self, kind: str, attributes: Mapping[str, Any]) -> tuple[float, str] | None:
        """(radius in metres, style) of the ring around a point of `kind`, if any."""
        look = self.kind(kind)
        radius = attributes.get(look.radius_field) if look.radius_field else None
        if isinstance(radius, (int, float)) and not isinstance(radius, bool) \
                and 0 < radius < 1e7:
            return float(radius), look.radius_style
        return None

    def line_style(self, kind: str, attributes: Mapping[str, Any]) -> str:
        """The style of the lines (or fill) of a shape of `kind`."""
        return self._styled(self.kind(kind), attributes, AREA_STYLE)

    @staticmethod
    def _styled(look: KindStyle, attributes: Mapping[str, Any], default: str) -> str:
        if look.state_field:
            state = attributes.get(look.state_field)
            if isinstance(state, (str, int, float)) and not isinstance(state, bool) \
                    and str(state) in look.states:
                return look.states[str(state)]
        return look.style or default


def read_map(section: Any, *, file: str = "") -> MapConfig:
    """The `[map]` table (absent: the defaults); ConfigError naming the key."""
    if section is None:
        return MapConfig()
    if not isinstance(section, Mapping):
        raise ConfigError("must be a table", file=file, key=SECTION)
    kinds: dict[str, KindStyle] = {}
    hide: frozenset[str] = frozenset()
    for key, value in section.items():
        where = f"{SECTION}.{key}"
        if key == "hide":
            if not isinstance(value, list) or not all(isinstance(v, str) and v
                                                      for v in value):
                raise ConfigError("must be a list of world-model kinds, e.g. [\"robot\"]",
                                  file=file, key=where)
            hide = frozenset(value)
        elif key == "kinds":
            if not isinstance(value, Mapping):
                raise ConfigError("must be a table of [map.kinds.<kind>] tables",
                                  file=file, key=where)
            kinds = {str(kind): _kind(table, file, f"{where}.{kind}")
                     for kind, table in value.items()}
        else:
            raise ConfigError(f"unknown key{_hint(key, ['hide', 'kinds'])}", file=file,
                              key=where)
    return MapConfig(kinds, hide)


def _kind(table: Any, file: str, where: str) -> KindStyle:
    if not isinstance(table, Mapping):
        raise ConfigError(f"must be a table ({', '.join(k.value for k in KindKey)})",
                          file=file, key=where)
    known = [k.value for k in KindKey]
    values: dict[str, Any] = {}
    for key, value in table.items():
        at = f"{where}.{key}"
        if key not in known:
            raise ConfigError(f"unknown key{_hint(key, known)}", file=file, key=at)
        if key == KindKey.GLYPH:
            if not isinstance(value, str) or len(value) != 1 or not value.isprintable() \
                    or value.isspace() or cell_len(value) != 1:
                raise ConfigError(f"must be one printable character one cell wide, not "
                                  f"{value!r}",
                                  file=file, key=at)
        elif key in (KindKey.STYLE, KindKey.RADIUS_STYLE):
            value = _style(value, file, at)
        elif key in (KindKey.STATE_FIELD, KindKey.RADIUS_FIELD):
            if not isinstance(value, str) or not value:
                raise ConfigError("must be the name of an attribute, e.g. \"state\" or "
                                  "\"comm_radius_m\"", file=file, key=at)
        elif key == KindKey.STATES:
            if not isinstance(value, Mapping):
                raise ConfigError("must be a table of state = \"style\"", file=file, key=at)
            value = {str(state): _style(style, file, f"{at}.{state}")
                     for state, style in value.items()}
        elif key == KindKey.POLYGON:
            choices = [p.value for p in PolygonDraw]
            if value not in choices:
                raise ConfigError(f"must be one of {', '.join(map(repr, choices))}, "
                                  f"not {value!r}", file=file, key=at)
            value = PolygonDraw(value)
        elif not isinstance(value, bool):
            raise ConfigError(f"must be true or false, not {value!r}", file=file, key=at)
        values[key] = value
    if values.get(KindKey.STATES) and not values.get(KindKey.STATE_FIELD):
        raise ConfigError("states need a state_field (the attribute that holds the state)",
                          file=file, key=f"{where}.states")
    return KindStyle(**values)


def _style(value: Any, file: str, where: str) -> str:
    """A Rich style such as "bold red" or "dim green on black"; ConfigError else."""
    if not isinstance(value, str) or not value.strip():
        raise ConfigError(f"must be a style such as \"bold red\", not {value!r}", file=file,
                          key=where)
    try:
        Style.parse(value)
    except StyleSyntaxError as exc:
        raise ConfigError(f"not a style: {exc}", file=file, key=where) from None
    return value.strip()


def _hint(word: str, known: list[str]) -> str:
    close = difflib.get_close_matches(word, known, n=1)
    hint = f"; did you mean {close[0]!r}?" if close else ""
    return f" {word!r}{hint} (known: {', '.join(known)})"
