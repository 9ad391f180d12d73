"""What the operator draws on the map: a cursor and the vertices placed with it, made
into a point, a circle or a polygon for a command's field. Pure Python: no Textual.

The cursor starts at the view's centre and moves a cell at a time (`move`); `add` puts
a vertex where it is, `undo` takes the last one off. `point()` is the cursor (or the one
vertex); `circle()` is centred on the first vertex, its radius the distance to the
cursor (or to the second vertex); `polygon()` is the vertices in order. Each is checked
as a command's field would check it (`mrss.config.operator_commands`: a position on the
globe; a polygon of 3 to `HARD_MAX_VERTICES` vertices that does not cross itself, with
shapely), and `SketchError` says what is wrong; the result is the field's text
(`LAT,LON`, `LAT,LON,RADIUS`, `LAT,LON; LAT,LON; ...`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from mrss.config.operator_commands import (
    HARD_MAX_VERTICES,
    CommandError,
    FieldSpec,
    FieldType,
)
from mrss.tui.models.geo import METRES_PER_DEGREE


class SketchError(ValueError):
    """A drawing that is not the shape asked for; the text says why."""


def _text(lat: float, lon: float) -> str:
    return f"{lat:.6f},{lon:.6f}"


def distance_m(a: tuple[float, float], b: tuple[float, float]) -> float:
    """Metres between two (lat, lon), equirectangular (a mission area's few km)."""
    north = (b[0] - a[0]) * METRES_PER_DEGREE
    east = (b[1] - a[1]) * METRES_PER_DEGREE * math.cos(math.radians((a[0] + b[0]) / 2))
    return math.hypot(north, east)


@dataclass
class Sketch:
    """The cursor (None: off) and the vertices placed."""

    cursor: tuple[float, float] | None = None
    vertices: list[tuple[float, float]] = field(default_factory=list)

    def add(self) -> int:
        """A vertex at the cursor; how many there are. SketchError past the limit."""
        if self.cursor is None:
            raise SketchError("no cursor on the map (space shows it)")
        if len(self.vertices) >= HARD_MAX_VERTICES:
            raise SketchError(f"at most {HARD_MAX_VERTICES} vertices: the shape has them all")
        self.vertices.append(self.cursor)
        return len(self.vertices)

    def undo(self) -> int:
        if self.vertices:
            self.vertices.pop()
        return len(self.vertices)

    def clear(self) -> None:
        self.vertices.clear()

    def point(self) -> str:
        where = self.vertices[0] if len(self.vertices) == 1 else self.cursor
        if where is None or len(self.vertices) > 1:
            raise SketchError("a point is the cursor or one vertex, not "
                              f"{len(self.vertices)} vertices")
        self._check(FieldType.POINT, [where[0], where[1]])
        return _text(*where)

    def circle(self) -> str:
        if not self.vertices:
            raise SketchError("a circle needs its centre: put a vertex there (Enter), then "
                              "move the cursor to its edge")
        centre = self.vertices[0]
        edge = self.vertices[1] if len(self.vertices) >= 2 else self.cursor
        if edge is None or len(self.vertices) > 2:
            raise SketchError(f"a circle is a centre and an edge, not {len(self.vertices)} "
                              "vertices")
        radius = round(distance_m(centre, edge), 1)
        if radius <= 0:
            raise SketchError("the circle has no radius: move the cursor off its centre")
        self._check(FieldType.POINT, [centre[0], centre[1]])
        return f"{_text(*centre)},{radius:g}"

    def polygon(self) -> str:
        self._check(FieldType.POLYGON, [[lat, lon] for lat, lon in self.vertices])
        return "; ".join(_text(*v) for v in self.vertices)

    @staticmethod
    def _check(kind: FieldType, value: object) -> None:
        spec = FieldSpec(name=kind.value, type=kind, max_vertices=HARD_MAX_VERTICES)
        try:
            spec.check(value)
        except CommandError as exc:
            raise SketchError(str(exc)) from None
