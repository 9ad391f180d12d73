"""What the map panel shows: robots (position, heading, a short track) and their plans
(`plan` robot data, mrss.messages.plans: the path flown dim, the path left bright) from robot
data, and the world model's objects (hotspots, water sources, bases as points; operator
areas and other shapes as outlines) from its `wm.list` answers, styled by the project's
`[map]` table (mrss.config.map), and the active stand-downs by area (the RCL's
`fleet.stand_down`) as red outlines with their id and mode. Drawn onto a braille
canvas through a `Viewport`. Pure Python: no Textual.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from mrss.config.map import MapConfig, PolygonDraw
from mrss.messages import ActionState, ActionStatus, RobotData, StandDownState
from mrss.messages.plans import PLAN_MAX_WAYPOINTS, PLAN_RECORD
from mrss.tui.models.braille import BrailleCanvas
from mrss.tui.models.geo import DOTS_X, DOTS_Y, METRES_PER_DEGREE, Viewport, heading_arrow

TRACK_LENGTH = 30  # recent positions kept per robot
RING_VERTICES = 48  # of a `radius_field` ring
ToDots = Callable[[list[tuple[float, float]]], list[tuple[float, float]]]
ENDED = frozenset(s.value for s in ActionState if s.terminal)
ROBOT_STYLES = ("bold cyan", "bold magenta", "bold green", "bold yellow", "bold blue")
STAND_DOWN_STYLE = "bold red"  # an active stand-down by area (mrss.tui.stand_down)


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
    attributes: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class Plan:
    """A robot's planned path: `next` waypoints of it reached (mrss.messages.plans)."""

    action: str
    waypoints: list[tuple[float, float]]
    next: int


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


def plan_of(data: dict[str, Any]) -> Plan | None:
    """The Plan of a well-formed `plan` record (no waypoints: an empty plan), else None."""
    action, waypoints, reached = data.get("action"), data.get("waypoints"), data.get("next")
    if not isinstance(action, str) or not isinstance(waypoints, list) \
            or len(waypoints) > PLAN_MAX_WAYPOINTS:
        return None
    points: list[tuple[float, float]] = []
    for item in waypoints:
        if not isinstance(item, list) or len(item) != 2:
            return None
        lat, lon = _number(item[0]), _number(item[1])
        if lat is None or lon is None or abs(lat) > 90 or abs(lon) > 180:
            return None
        points.append((lat, lon))
    if isinstance(reached, bool) or not isinstance(reached, int) \
            or not 0 <= reached <= len(points):
        return None
    return Plan(action, points, reached)


def ring_points(lat: float, lon: float, radius_m: float) -> list[tuple[float, float]]:
    """A closed ring of RING_VERTICES (lat, lon) `radius_m` around a point."""
    north = radius_m / METRES_PER_DEGREE
    east = north / max(1e-6, math.cos(math.radians(lat)))
    ring = [(lat + north * math.cos(2 * math.pi * i / RING_VERTICES),
             lon + east * math.sin(2 * math.pi * i / RING_VERTICES))
            for i in range(RING_VERTICES)]
    return [*ring, ring[0]]


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


class ObjectsLayer:
    """The world objects' areas and rings alone, as a map panel last drew them: drawn
    again only when the objects or the view changed (a world model answer every 2 s is
    mostly the same, and its 40 areas were most of a map drawing, `mrss bench tui`).
    Kept by the panel, not the model: it is how one view looks, not mission state."""

    def __init__(self) -> None:
        self._drawn: list[WorldShape] = []  # the objects with lines or a ring, drawn
        self._key: tuple[float, float, float, int, int] | None = None
        self._canvas = BrailleCanvas(0, 0)

    def canvas(self, model: MapModel, view: Viewport, width: int, height: int,
               dots: Callable[[list[tuple[float, float]]], list[tuple[float, float]]]
               ) -> BrailleCanvas:
        """The layer for `model`'s objects in `view` (not to be drawn into)."""
        styles = model.styles
        rings = {shape.id: styles.ring(shape.kind, shape.attributes)
                 for shape in model.objects.values() if shape.point is not None}
        drawn = [shape for shape in model.objects.values()
                 if shape.lines or rings.get(shape.id) is not None]
        key = (view.lat, view.lon, view.scale, width, height)
        if self._key == key and len(drawn) == len(self._drawn) \
                and all(a is b for a, b in zip(drawn, self._drawn, strict=True)):
            return self._canvas  # the same objects (`MapModel.apply_world` keeps them)
        canvas = BrailleCanvas(width, height)
        for shape in drawn:
            style = styles.line_style(shape.kind, shape.attributes)
            fill = styles.kind(shape.kind).polygon is PolygonDraw.FILL
            for line in shape.lines:
                if fill and len(line) >= 3:
                    canvas.fill_polygon(dots(line), style)
                canvas.polyline(dots(line), style)
        for shape in drawn:
            ring = rings.get(shape.id)
            if shape.point is not None and ring is not None:
                canvas.polyline(dots(ring_points(*shape.point, ring[0])), ring[1])
        self._drawn, self._key, self._canvas = drawn, key, canvas
        return canvas


class MapModel:
    """Robots by id (first heard first) and the world model's objects by id."""

    def __init__(self, styles: MapConfig | None = None) -> None:
        self.robots: dict[str, RobotMark] = {}
        self.objects: dict[str, WorldShape] = {}
        self.plans: dict[str, Plan] = {}  # robot -> its plan
        self.stand_downs: dict[str, StandDownState] = {}  # active ones, by id
        self.world_error = ""
        self.styles = styles or MapConfig()

    def apply_data(self, data: RobotData) -> bool:
        """A robot data message; True if it moved (or placed) a robot or changed its plan.
        A malformed plan is ignored; an empty one clears the robot's plan of its action."""
        if data.data.get("type") == PLAN_RECORD:
            return self._apply_plan(data.robot, data.data)
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

    def _apply_plan(self, robot: str, data: dict[str, Any]) -> bool:
        plan = plan_of(data)
        if plan is None:
            return False
        if plan.waypoints:
            self.plans[robot] = plan
            return True
        current = self.plans.get(robot)
        if current is None or current.action != plan.action:
            return False  # the end of a plan that another one replaced already
        del self.plans[robot]
        return True

    def apply_status(self, status: ActionStatus) -> bool:
        """An action that ended takes its plan off the map (the RCL also says so with an
        empty plan; this covers an RCL restarted meanwhile); True if one went."""
        if status.state not in ENDED:
            return False
        ended = [robot for robot, plan in self.plans.items() if plan.action == status.uuid]
        for robot in ended:
            del self.plans[robot]
        return bool(ended)

    def apply_stand_down(self, state: StandDownState) -> bool:
        """The RCL's word on a stand-down by area: shown while active."""
        if state.active:
            self.stand_downs[state.ident] = state
            return True
        return self.stand_downs.pop(state.ident, None) is not None

    def apply_world(self, objects: Any) -> bool:
        """The answer to `wm.list`: replaces every object; False if it is not a list."""
        if not isinstance(objects, list):
            return False
        shapes: dict[str, WorldShape] = {}
        for obj in objects:
            if not isinstance(obj, dict) or not isinstance(obj.get("id"), str):
                continue
            shape = WorldShape(obj["id"], str(obj.get("kind", "")))
            if shape.kind in self.styles.hide:
                continue
            attributes = obj.get("attributes")
            if isinstance(attributes, dict):
                shape.attributes = attributes
            pos = obj.get("position")
            if isinstance(pos, dict):
                lat, lon = _number(pos.get("lat")), _number(pos.get("lon"))
                if lat is not None and lon is not None:
                    shape.point = (lat, lon)
            shape.lines = _geometry_lines(obj.get("geometry"))
            if shape.point is not None or shape.lines:
                before = self.objects.get(shape.id)
                # an object as it was is kept as it was (the map's drawn layer of the
                # areas stays while only the robots move)
                shapes[shape.id] = before if before == shape else shape
        self.objects = shapes
        self.world_error = ""
        return True

    def points(self) -> list[tuple[float, float]]:
        """Every position on the map (to fit the view to)."""
        pts = [(m.lat, m.lon) for m in self.robots.values()]
        for plan in self.plans.values():
            pts.extend(plan.waypoints)
        for shape in self.objects.values():
            if shape.point is not None:
                pts.append(shape.point)
                ring = self.styles.ring(shape.kind, shape.attributes)
                if ring is not None:
                    pts.extend(ring_points(*shape.point, ring[0])[::RING_VERTICES // 4])
            pts.extend(p for line in shape.lines for p in line)
        return pts

    def draw(self, view: Viewport, width: int, height: int,
             layer: ObjectsLayer | None = None) -> BrailleCanvas:
        """Areas and rings, then tracks and plans (dots), then the characters: robots
        with their names first, so that they are on top and their names whole, then
        objects and their names, then areas' names, each where the cell is still free."""
        def dots(line: list[tuple[float, float]]) -> list[tuple[float, float]]:
            return [view.to_dots(lat, lon, width, height) for lat, lon in line]

        canvas = (layer or ObjectsLayer()).canvas(self, view, width, height, dots).copy()
        for held in self.stand_downs.values():  # the operator's stand-downs, in red
            for line in _geometry_lines(held.area):
                canvas.polyline(dots(line), STAND_DOWN_STYLE)
        for i, mark in enumerate(self.robots.values()):
            style = ROBOT_STYLES[i % len(ROBOT_STYLES)]
            canvas.polyline(dots(list(mark.track)), style.replace("bold ", "dim "))
        for robot, plan in self.plans.items():
            self._draw_plan(canvas, dots, robot, plan)
        for (col, row), marks in self.robots_by_cell(view, width, height).items():
            mark = marks[0]  # robots at one spot: the first, and how many more (l lists them)
            style = self.robot_style(mark.robot)
            name = mark.robot if len(marks) == 1 else f"{mark.robot}+{len(marks) - 1}"
            if canvas.glyph(col, row, heading_arrow(mark.heading), style):
                canvas.label(col + 1, row, name, style)
        for shape in self.objects.values():
            if shape.point is None:
                continue
            char, style = self.styles.point_look(shape.kind, shape.attributes)
            col, row = view.to_cell(*shape.point, width, height)
            if canvas.glyph(col, row, char, style, over=False) \
                    and self.styles.kind(shape.kind).label:
                canvas.label(col + 1, row, shape.id, "dim")
        for held in self.stand_downs.values():
            for line in _geometry_lines(held.area)[:1]:
                col, row = view.to_cell(*line[0], width, height)
                canvas.label(col, row, f"{held.ident} {held.mode.value}", STAND_DOWN_STYLE)
        for shape in self.objects.values():
            if shape.lines and shape.point is None and self.styles.kind(shape.kind).label:
                style = self.styles.line_style(shape.kind, shape.attributes)
                col, row = view.to_cell(*shape.lines[0][0], width, height)
                canvas.label(col, row, self.shape_label(shape), style)
        return canvas

    def shape_label(self, shape: WorldShape) -> str:
        """An area's name, with its state when its kind has one (`x1 lifted`)."""
        state_field = self.styles.kind(shape.kind).state_field
        state = shape.attributes.get(state_field) if state_field else None
        return f"{shape.id} {state}" if isinstance(state, str) and state else shape.id

    def robots_by_cell(self, view: Viewport, width: int, height: int
                       ) -> dict[tuple[int, int], list[RobotMark]]:
        """The robots in each terminal cell, first heard of first."""
        cells: dict[tuple[int, int], list[RobotMark]] = {}
        for mark in self.robots.values():
            cells.setdefault(view.to_cell(mark.lat, mark.lon, width, height), []).append(mark)
        return cells

    def robot_style(self, robot: str) -> str:
        """The style of a robot's marker (by the order robots were first heard of)."""
        robots = list(self.robots)
        index = robots.index(robot) if robot in robots else len(robots)
        return ROBOT_STYLES[index % len(ROBOT_STYLES)]

    def _draw_plan(self, canvas: BrailleCanvas, dots: ToDots, robot: str, plan: Plan) -> None:
        """Done: the waypoints reached, dim; left: from the robot (or the last waypoint
        reached) on through the rest, in the robot's colour."""
        colour = self.robot_style(robot).replace("bold ", "")
        done, left = plan.waypoints[:plan.next], plan.waypoints[plan.next:]
        canvas.polyline(dots(done), f"dim {colour}")
        mark = self.robots.get(robot)
        lead = [(mark.lat, mark.lon)] if mark is not None else done[-1:]
        canvas.polyline(dots(lead + left), f"bold {colour}")


def cell_of(view: Viewport, lat: float, lon: float, width: int,
            height: int) -> tuple[int, int]:
    """The (column, row) of a position: `Viewport.to_cell`, for callers without geo."""
    x, y = view.to_dots(lat, lon, width, height)
    return math.floor(x / DOTS_X), math.floor(y / DOTS_Y)
