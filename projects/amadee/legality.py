"""The operational rules of the AMADEE-24 rover: is an action legal here and now?

`verdict(action, rover, world)` checks one action against every rule and returns the
first one that forbids it (`Verdict.legal` False, with the rule's name and the geometry
involved), or a legal verdict. The rules read their data from the world model:

- zones are polygons: kind `no_go` (never driven through) and `protected` (never driven
  through, never sampled in);
- crew on EVA are points of kind `crew`;
- terrain grids (elevations) are objects of kind `terrain` (terrain.py);
- time windows (e.g. a declared comms blackout) are objects of kind `time_window`:
  `start` and `end` (ISO 8601 with a time zone) and `forbids` (action names);
- the habitat is the object `habitat`; its attributes are the parameters:
  `comm_radius_m` (the communication zone around it), `crew_safety_m`,
  `energy_per_m` (% of battery per metre driven), `battery_reserve` (% left on return),
  `max_slope_deg` (the steepest slope the rover may drive), `stopped_mps` (the speed
  under which the rover counts as stopped for the arm).

Actions are `drive(R, G, Lat, Lon)`, `image(R, G)`, `spectrum(R, G)`, `radar(R, G)`,
`sample(R, G)` and `return_home(R, G)`; the arm deploys for `spectrum` and `sample`.

A rule is a function `(Request, world) -> Verdict | None` in RULES: add one there (and a
test in procedures/test_amadee_rules.py).
"""

from __future__ import annotations

import json
import re
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Any, Protocol

from mrss.api import NoExit, distance_m, import_project_module, shortest_exit

terrain = import_project_module(Path(__file__).resolve().parent, "terrain.py")

HABITAT = "habitat"
ARM_ACTIONS = frozenset({"spectrum", "sample"})
SCIENCE_ACTIONS = frozenset({"image", "spectrum", "radar", "sample"})
MOVE_ACTIONS = frozenset({"drive", "return_home"})
STOPPED_MPS = 0.05
ESCAPE_TOLERANCE_M = 3.0   # how near the shortest exit a drive out of a no-go zone ends
_ACTION_RE = re.compile(r"^\s*([a-z][a-zA-Z0-9_]*)\s*(?:\((.*)\))?\s*$", re.DOTALL)


class SpatialWorld(Protocol):
    """What the rules ask of the world model (the data layer's `self.world`)."""

    def get(self, object_id: str) -> dict[str, Any] | None: ...

    def objects(self, kind: str | None = None) -> list[dict[str, Any]]: ...

    def intersecting(self, geometry: dict[str, Any],
                     kind: str | None = None) -> list[dict[str, Any]]: ...

    def within_distance(self, geometry: dict[str, Any], distance_m: float,
                        kind: str | None = None) -> list[dict[str, Any]]: ...


@dataclass(frozen=True)
class Verdict:
    """Legal, or illegal by `rule` with a `detail` naming the geometry involved."""

    legal: bool
    rule: str = ""
    detail: str = ""
    geometry: dict[str, Any] | None = None

    def as_answer(self) -> list[str]:
        """The answer of `query(legal, ...)`: ["legal"] or ["illegal", Rule, Detail]."""
        return ["legal"] if self.legal else ["illegal", self.rule, self.detail]


LEGAL = Verdict(True)


@dataclass(frozen=True)
class Rover:
    """The rover as the world model knows it."""

    lat: float
    lon: float
    speed: float = 0.0
    battery: float = 100.0


@dataclass(frozen=True)
class Request:
    """An action with what the rules need: where it goes, from where, with what rover."""

    name: str
    rover: Rover
    target: tuple[float, float] | None = None   # drive: the destination
    habitat: tuple[float, float] = (0.0, 0.0)
    params: dict[str, float] = field(default_factory=dict)
    now: float = field(default_factory=time.time)   # seconds since the epoch (UTC)

    def path(self) -> dict[str, Any] | None:
        """The driven segment as GeoJSON (lon, lat), None when the rover does not move
        (a task in place, or a drive to where it stands)."""
        if self.target is None or self.target == (self.rover.lat, self.rover.lon):
            return None
        return {"type": "LineString", "coordinates": [[self.rover.lon, self.rover.lat],
                                                      [self.target[1], self.target[0]]]}

    def here(self) -> dict[str, Any]:
        return {"type": "Point", "coordinates": [self.rover.lon, self.rover.lat]}


def parse_action(text: str) -> tuple[str, list[Any]]:
    """`drive(rover1,g1,39.77,44.8)` -> ("drive", ["rover1", "g1", 39.77, 44.8])."""
    match = _ACTION_RE.match(text)
    if match is None:
        raise ValueError(f"not an action: {text!r}")
    args: list[Any] = []
    for raw in (match.group(2) or "").split(","):
        item = raw.strip().strip('"')
        if not item:
            continue
        try:
            args.append(float(item))
        except ValueError:
            args.append(item)
    return match.group(1), args


def goal_of(text: str) -> str | None:
    """The goal (second argument) of an action text, if it is an atom."""
    try:
        _, args = parse_action(text)
    except ValueError:
        return None
    goal = args[1] if len(args) > 1 else None
    return goal if isinstance(goal, str) and re.fullmatch(r"[a-z][a-zA-Z0-9_]*", goal) \
        else None


def request_of(text: str, world: SpatialWorld, now: float | None = None) -> Request:
    """The Request of an action text, with the rover and the habitat from the world;
    `now` (epoch seconds) defaults to the clock."""
    name, args = parse_action(text)
    if name not in SCIENCE_ACTIONS | MOVE_ACTIONS:
        raise ValueError(f"no rules for action {name!r}")
    if len(args) < 2 or not isinstance(args[0], str):
        raise ValueError(f"{name}: expected {name}(Robot, Goal, ...), got {text!r}")
    habitat = world.get(HABITAT)
    if habitat is None or not habitat.get("position"):
        raise LookupError("the world model has no 'habitat' with a position")
    home = (float(habitat["position"]["lat"]), float(habitat["position"]["lon"]))
    params = {k: float(v) for k, v in (habitat.get("attributes") or {}).items()
              if isinstance(v, (int, float)) and not isinstance(v, bool)}
    robot = world.get(args[0])
    if robot is None or not robot.get("position"):
        raise LookupError(f"no position of robot {args[0]!r} in the world model yet")
    attrs = robot.get("attributes") or {}
    rover = Rover(float(robot["position"]["lat"]), float(robot["position"]["lon"]),
                  float(attrs.get("speed", 0.0) or 0.0), float(attrs.get("battery", 100.0)))
    target: tuple[float, float] | None = None
    if name == "drive":
        if len(args) != 4 or not all(isinstance(a, float) for a in args[2:]):
            raise ValueError(f"drive: expected drive(Robot, Goal, Lat, Lon), got {text!r}")
        target = (args[2], args[3])
    elif name == "return_home":
        target = home
    return Request(name, rover, target, home, params,
                   time.time() if now is None else now)


# ------------------------------------------------------------------------------ rules
def _zones_crossed(kind: str, rule: str, why: str) -> Callable[[Request, SpatialWorld],
                                                               Verdict | None]:
    def check(request: Request, world: SpatialWorld) -> Verdict | None:
        path = request.path()
        if path is None:
            return None
        crossed = world.intersecting(path, kind)
        if not crossed:
            return None
        zone = crossed[0]
        return Verdict(False, rule, f"the path {_segment(request)} {why} {kind} zone "
                                    f"{zone['id']!r}", zone.get("geometry"))
    check.__name__ = check.__qualname__ = rule
    return check


_no_go_crossed = _zones_crossed("no_go", "no_go_path", "crosses")


def no_go_path(request: Request, world: SpatialWorld) -> Verdict | None:
    """No path through a no-go zone; a rover found inside one may only leave it, by the
    shortest legal path (the nearest point of its outline outside every other zone,
    ESCAPE_TOLERANCE_M given): any other move from inside is refused, naming the exit."""
    zones = world.intersecting(request.here(), "no_go")
    if not zones:
        return _no_go_crossed(request, world)
    try:
        way_out = shortest_exit(request.rover.lat, request.rover.lon, world.objects("no_go"))
    except NoExit as exc:
        return Verdict(False, "no_go_path", f"the rover at {_rover(request)} is inside "
                       f"no_go zone {zones[0]['id']!r}: {exc}", zones[0].get("geometry"))
    if way_out is None or request.target is None:
        return None
    if distance_m(*request.target, way_out.lat, way_out.lon) <= ESCAPE_TOLERANCE_M:
        return None   # the escape: it crosses no other zone (shortest_exit's promise)
    return Verdict(False, "no_go_path",
                   f"the rover at {_rover(request)} is inside no_go zone "
                   f"{way_out.zone!r}; it may only leave it by the shortest legal path, to "
                   f"{_point((way_out.lat, way_out.lon))} ({way_out.distance_m:.0f} m)",
                   zones[0].get("geometry"))
protected_path = _zones_crossed("protected", "protected_path", "crosses")


def slope_limit(request: Request, world: SpatialWorld) -> Verdict | None:
    """No stretch of the path steeper than `max_slope_deg` on any terrain grid it crosses."""
    limit = request.params.get("max_slope_deg")
    path = request.path()
    if limit is None or path is None or request.target is None:
        return None
    start = (request.rover.lat, request.rover.lon)
    for obj in world.intersecting(path, "terrain"):
        steepest = terrain.TerrainGrid.of(obj).steepest(start, request.target)
        if steepest is not None and steepest.slope_deg > limit:
            return Verdict(False, "slope_limit",
                           f"the path {_segment(request)} climbs {steepest.slope_deg:.1f}° "
                           f"between {_point(steepest.start)} and {_point(steepest.end)} "
                           f"on terrain {obj['id']!r}, steeper than {limit:g}°",
                           steepest.geometry())
    return None


def communication_zone(request: Request, world: SpatialWorld) -> Verdict | None:
    """Both ends of the path inside the circle around the habitat (so all of it is)."""
    radius = request.params.get("comm_radius_m")
    if radius is None or request.target is None:
        return None
    off = distance_m(*request.habitat, *request.target)
    if off <= radius:
        return None
    return Verdict(False, "communication_zone",
                   f"the target {_point(request.target)} is {off:.0f} m from the habitat, "
                   f"outside the communication zone of {radius:.0f} m",
                   {"type": "Point", "coordinates": [request.target[1], request.target[0]]})


def crew_safety(request: Request, world: SpatialWorld) -> Verdict | None:
    """No crew member on EVA within `crew_safety_m` of the path (or of the rover)."""
    margin = request.params.get("crew_safety_m")
    if margin is None:
        return None
    shape = request.path() or request.here()
    close = world.within_distance(shape, margin, "crew")
    if not close:
        return None
    crew = close[0]
    where = "the path " + _segment(request) if request.path() else "the rover"
    return Verdict(False, "crew_safety",
                   f"crew {crew['id']!r} is {float(crew.get('distance_m', 0.0)):.0f} m from "
                   f"{where}, closer than {margin:.0f} m", shape)


def battery_reserve(request: Request, world: SpatialWorld) -> Verdict | None:
    """Enough battery to drive there and back to the habitat with the reserve left."""
    per_m = request.params.get("energy_per_m")
    if per_m is None or request.target is None:
        return None
    reserve = request.params.get("battery_reserve", 0.0)
    there = distance_m(request.rover.lat, request.rover.lon, *request.target)
    back = distance_m(*request.target, *request.habitat)
    needed = per_m * (there + back) + reserve
    if request.rover.battery >= needed:
        return None
    return Verdict(False, "battery_reserve",
                   f"{there:.0f} m there and {back:.0f} m back need {needed:.1f}% with the "
                   f"{reserve:.0f}% reserve; the battery has {request.rover.battery:.1f}%",
                   request.path())


def time_window(request: Request, world: SpatialWorld) -> Verdict | None:
    """No action a time window forbids while it is open (a declared comms blackout)."""
    for obj in world.objects("time_window"):
        attrs = obj.get("attributes") or {}
        forbids = attrs.get("forbids", sorted(MOVE_ACTIONS))
        if not isinstance(forbids, list) or not all(isinstance(f, str) for f in forbids):
            raise ValueError(f"time window {obj['id']!r}: forbids must be a list of action "
                             f"names, not {forbids!r}")
        if request.name not in forbids:
            continue
        start, end = _instant(obj, "start"), _instant(obj, "end")
        if start <= request.now < end:
            what = f" ({attrs['what']})" if isinstance(attrs.get("what"), str) else ""
            return Verdict(False, "time_window",
                           f"{request.name} is forbidden by time window {obj['id']!r}{what} "
                           f"from {_utc(start)} to {_utc(end)}; it is {_utc(request.now)}",
                           request.path() or request.here())
    return None


def arm_when_stopped(request: Request, world: SpatialWorld) -> Verdict | None:
    """The arm deploys only at a speed of at most `stopped_mps` (default STOPPED_MPS)."""
    stopped = request.params.get("stopped_mps", STOPPED_MPS)
    if request.name not in ARM_ACTIONS or request.rover.speed <= stopped:
        return None
    return Verdict(False, "arm_when_stopped",
                   f"the arm deploys only when the rover is stopped (at most "
                   f"{stopped:g} m/s); it moves at "
                   f"{request.rover.speed:.2f} m/s at {_rover(request)}",
                   request.here())


def no_sampling_protected(request: Request, world: SpatialWorld) -> Verdict | None:
    if request.name != "sample":
        return None
    zones = world.intersecting(request.here(), "protected")
    if not zones:
        return None
    return Verdict(False, "no_sampling_protected",
                   f"the rover at {_rover(request)} is in "
                   f"protected zone {zones[0]['id']!r}", zones[0].get("geometry"))


RULES: tuple[Callable[[Request, SpatialWorld], Verdict | None], ...] = (
    time_window, no_go_path, protected_path, communication_zone, crew_safety,
    slope_limit, battery_reserve, arm_when_stopped, no_sampling_protected)


class SharedQueries:
    """The world as one check's rules see it: the rules asking which objects of some
    kind a shape meets share one question to the world model per shape (all kinds,
    filtered here), so a check costs a few round trips, not one per rule."""

    def __init__(self, world: SpatialWorld) -> None:
        self.world = world
        self._met: dict[str, list[dict[str, Any]]] = {}

    def get(self, object_id: str) -> dict[str, Any] | None:
        return self.world.get(object_id)

    def objects(self, kind: str | None = None) -> list[dict[str, Any]]:
        return self.world.objects(kind)

    def intersecting(self, geometry: dict[str, Any],
                     kind: str | None = None) -> list[dict[str, Any]]:
        key = json.dumps(geometry, sort_keys=True)
        if key not in self._met:
            self._met[key] = self.world.intersecting(geometry)
        return [o for o in self._met[key] if kind is None or o.get("kind") == kind]

    def within_distance(self, geometry: dict[str, Any], distance_m: float,
                        kind: str | None = None) -> list[dict[str, Any]]:
        return self.world.within_distance(geometry, distance_m, kind)


def verdict(request: Request, world: SpatialWorld) -> Verdict:
    """The first rule that forbids `request`, or LEGAL."""
    shared = SharedQueries(world)
    for rule in RULES:
        found = rule(request, shared)
        if found is not None:
            return found
    return LEGAL


def judge(action: str, world: SpatialWorld, now: float | None = None) -> Verdict:
    """The verdict on an action text; one that cannot be checked (a malformed action, no
    rover position yet, no habitat, a rule's data malformed) is refused by the rule
    `unchecked`, with the reason."""
    try:
        return verdict(request_of(action, world, now), world)
    except (ValueError, LookupError) as exc:
        return Verdict(False, "unchecked", f"cannot check {action}: {exc}")


def _instant(obj: dict[str, Any], key: str) -> float:
    """A time window's `start` or `end`: ISO 8601 with a zone -> epoch seconds."""
    value = (obj.get("attributes") or {}).get(key)
    try:
        moment = datetime.fromisoformat(str(value))
    except ValueError:
        moment = None
    if not isinstance(value, str) or moment is None or moment.tzinfo is None:
        raise ValueError(f"time window {obj.get('id')!r}: {key} must be an ISO 8601 time "
                         f"with a zone (2026-11-25T14:00:00Z), not {value!r}")
    return moment.timestamp()


def _utc(epoch: float) -> str:
    return time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime(epoch))


def _point(p: tuple[float, float]) -> str:
    return f"{p[0]:.6f},{p[1]:.6f}"


def _rover(request: Request) -> str:
    return _point((request.rover.lat, request.rover.lon))


def _segment(request: Request) -> str:
    assert request.target is not None
    return f"{_rover(request)} -> {_point(request.target)}"
