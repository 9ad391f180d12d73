"""What the map panel shows: robots (position, heading, a short track) from telemetry,
and the world model's objects (hotspots, water sources, bases as points; operator areas
and other shapes as outlines) from its `wm.list` answers. Drawn onto a braille canvas
through a `Viewport`. Pure Python: no Textual.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field
from typing import Any

from mrss.messages import RobotData
from mrss.tui.models.braille import BrailleCanvas
from mrss.tui.models.geo import DOTS_X, DOTS_Y, Viewport, heading_arrow

TRACK_LENGTH = 30  # recent positions kept per robot
ROBOT_STYLES = ("bold cyan", "bold magenta", "bold green", "bold yellow", "bold blue")
# glyph and style per world-model kind; any other kind shows its initial
KIND_GLYPHS = {"hotspot": ("✹", "bold red"), "water_source": ("≈", "bold blue"),
               "base": ("⌂", "bold green"), "robot": ("○", "dim")}
AREA_STYLE = "yellow"


@dataclass
class RobotMark:
    """A robot's latest position and heading, and where it has been."""

    robot: str
    lat: float
    lon: float
    heading: float | None = None
    track: deque[tuple[float, float]] = field(default_factory=lambda: deque(maxlen=TRACK_LENGTH))


@dataclass
class WorldShape:
    """One world-model object: a point, or lines of (lat, lon) (an area's ring closes)."""

    id: str
    kind: str
    point: tuple[float, float] | None = None
    lines: list[list[tuple[float, float]]] = field(default_factory=list)


def _number(value: Any) -> float | None:
    if isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value):
        return float(value)
    return None


def telemetry_position(data: dict[str, Any]) -> tuple[float, float, float | None] | None:
    """(lat, lon, heading) of a telemetry record: a `position` link record or a flat map."""
    kind = data.get("type")
    if isinstance(kind, str) and kind and kind != "position":
        return None
    lat, lon = _number(data.get("lat")), _number(data.get("lon"))
    if lat is None or lon is None or abs(lat) > 90 or abs(lon) > 180:
        return None
    return lat, lon, _number(data.get("heading"))


def _geometry_lines(geometry: Any) -> list[list[tuple[float, float]]]:
    """GeoJSON LineString / Polygon / Multi* as lines of (lat, lon)."""
    if not isinstance(geometry, dict):
        return []
    kind, coords = geometry.get("type"), geometry.get("coordinates")
    parts: list[Any]
    if kind == "LineString":
        parts = [coords]
    elif kind in ("Polygon", "MultiLineString"):
        parts = list(coords or [])
    elif kind == "MultiPolygon":
        parts = [ring for poly in coords or [] for ring in poly]
    else:
        return []
    lines = []
    for part in parts:
        line = [(float(p[1]), float(p[0])) for p in part or []
                if isinstance(p, list) and len(p) >= 2 and _number(p[0]) is not None
                and _number(p[1]) is not None]
        if len(line) >= 2:
            lines.append(line)
    return lines


class MapModel:
    """Robots by id (first heard first) and the world model's objects by id."""

    def __init__(self) -> None:
        self.robots: dict[str, RobotMark] = {}
        self.objects: dict[str, WorldShape] = {}
        self.world_error = ""

    def apply_data(self, data: RobotData) -> bool:
        """A telemetry message; True if it moved (or placed) a robot."""
        found = telemetry_position(data.data)
        if found is None:
            return False
        lat, lon, heading = found
        mark = self.robots.get(data.robot)
        if mark is None:
            mark = self.robots[data.robot] = RobotMark(data.robot, lat, lon)
        mark.lat, mark.lon = lat, lon
        if heading is not None:
            mark.heading = heading
        if not mark.track or mark.track[-1] != (lat, lon):
            mark.track.append((lat, lon))
        return True

    def apply_world(self, objects: Any) -> bool:
        """The answer to `wm.list`: replaces every object; False if it is not a list."""
        if not isinstance(objects, list):
            return False
        shapes: dict[str, WorldShape] = {}
        for obj in objects:
            if not isinstance(obj, dict) or not isinstance(obj.get("id"), str):
                continue
            shape = WorldShape(obj["id"], str(obj.get("kind", "")))
            pos = obj.get("position")
            if isinstance(pos, dict):
                lat, lon = _number(pos.get("lat")), _number(pos.get("lon"))
                if lat is not None and lon is not None:
                    shape.point = (lat, lon)
            shape.lines = _geometry_lines(obj.get("geometry"))
            if shape.point is not None or shape.lines:
                shapes[shape.id] = shape
        self.objects = shapes
        self.world_error = ""
        return True

    def points(self) -> list[tuple[float, float]]:
        """Every position on the map (to fit the view to)."""
        pts = [(m.lat, m.lon) for m in self.robots.values()]
        for shape in self.objects.values():
            if shape.point is not None:
                pts.append(shape.point)
            pts.extend(p for line in shape.lines for p in line)
        return pts

    def draw(self, view: Viewport, width: int, height: int) -> BrailleCanvas:
        """Areas, then tracks, then objects, then robots (on top) with their names."""
        canvas = BrailleCanvas(width, height)
        for shape in self.objects.values():
            for line in shape.lines:
                dots = [view.to_dots(lat, lon, width, height) for lat, lon in line]
                for (x0, y0), (x1, y1) in zip(dots, dots[1:], strict=False):
                    canvas.line(x0, y0, x1, y1, AREA_STYLE)
            if shape.lines and shape.point is None:
                lat, lon = shape.lines[0][0]
                col, row = view.to_cell(lat, lon, width, height)
                canvas.label(col, row, shape.id, AREA_STYLE)
        for i, mark in enumerate(self.robots.values()):
            style = ROBOT_STYLES[i % len(ROBOT_STYLES)]
            dots = [view.to_dots(lat, lon, width, height) for lat, lon in mark.track]
            for (x0, y0), (x1, y1) in zip(dots, dots[1:], strict=False):
                canvas.line(x0, y0, x1, y1, style.replace("bold ", "dim "))
        for shape in self.objects.values():
            if shape.point is None:
                continue
            char, style = KIND_GLYPHS.get(shape.kind, ((shape.kind or "?")[0], "bold"))
            col, row = view.to_cell(*shape.point, width, height)
            if canvas.glyph(col, row, char, style):
                canvas.label(col + 1, row, shape.id, "dim")
        for i, mark in enumerate(self.robots.values()):
            style = ROBOT_STYLES[i % len(ROBOT_STYLES)]
            col, row = view.to_cell(mark.lat, mark.lon, width, height)
            if canvas.glyph(col, row, heading_arrow(mark.heading), style):
                canvas.label(col + 1, row, mark.robot, style)
        return canvas


def cell_of(view: Viewport, lat: float, lon: float, width: int,
            height: int) -> tuple[int, int]:
    """The (column, row) of a position: `Viewport.to_cell`, for callers without geo."""
    x, y = view.to_dots(lat, lon, width, height)
    return math.floor(x / DOTS_X), math.floor(y / DOTS_Y)
