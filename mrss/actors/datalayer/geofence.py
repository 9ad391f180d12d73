"""The geofence: a robot found stopped inside a no-go zone is given its way out.

Turned on by `[datalayer] geofence = true` (off by default). The data layer sees every
robot's position; when one stands still (speed below `geofence_stopped_mps`) inside a
zone of the world model whose kind is in `geofence_kinds`, the geofence computes its
shortest legal way out (`mrss.world.escape.shortest_exit`: the nearest point of the
zone's outline, `geofence_margin_m` beyond it, outside every other zone, on a straight
segment that meets none) and tells the agent by a percept:

    geofence_exit(Robot, Zone, Lat, Lon)   the way out: drive there, then go on
    geofence_trapped(Robot, Zone)          every way out crosses another zone: stay put

Each is added once, replaced when the finding changes (the robot stopped elsewhere in
the zone, a zone appeared or went), and removed when the robot is seen outside every
zone. A robot trapped is logged as an error once (until it is out or finds a way), a
robot leaving as a warning once; the dashboard raises an alert for both. The geofence
commands nothing: the agent drives (it knows the project's action for a drive, and
checks it like any other), so a project whose agent has no plan for the percept still
gets the alert. A look at one robot, and at the zones, happens at most every
`geofence_interval` seconds.

What it told survives a restart of the data layer (the agent keeps its percepts when the
data layer dies, `mrss.actors.reasoner.percept_ledger`): each percept is written to
`ToldPercepts` (`<run_dir>/<component>-geofence.sqlite3`) before it is sent. A new
incarnation reads them at its start: the removals the previous one may not have got
through are sent again, and the percepts it left standing are taken over, so the first
look at the robot that tells removes them (the robot is out), replaces them (it stopped
elsewhere) or tells them again (unchanged: the agent, which holds it, sees nothing new).
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from enum import StrEnum
from typing import Any, ClassVar

from shapely.geometry import Point, shape
from shapely.geometry.base import BaseGeometry

from mrss.actors.datalayer.told_percepts import Told, ToldPercepts
from mrss.agentspeak.literals import literal, symbol
from mrss.errors import ConfigError
from mrss.links.geo import distance_m
from mrss.options import Check, Option, OptionValues
from mrss.runtime.percepts import PerceptPublisher
from mrss.world.access import WorldModelAccess
from mrss.world.escape import NoExit, shortest_exit

log = logging.getLogger("mrss.datalayer.geofence")

EXIT = "geofence_exit"
TRAPPED = "geofence_trapped"


class Finding(StrEnum):
    """What one look at a robot found."""

    MOVING = "moving"      # inside a zone but not stopped: nothing to do yet
    OUTSIDE = "outside"    # in no zone
    EXIT = "exit"          # stopped inside, with a way out
    TRAPPED = "trapped"    # stopped inside, every way out crosses another zone


@dataclass
class _Robot:
    percept: str = ""                           # the literal the agent holds, "" if none
    finding: Finding = Finding.OUTSIDE
    looked: float = -math.inf                   # monotonic time of the last look
    fix: tuple[float, float, float] | None = None   # lat, lon, monotonic time
    stale: tuple[str, ...] = ()   # told by a previous incarnation: settled at the next tell


@dataclass(frozen=True)
class _Zone:
    ident: str
    raw: Mapping[str, Any]
    outline: BaseGeometry


class Geofence:
    """Watches positions for `observe`; publishes through `percept`."""

    #: The [datalayer] keys it reads (DataLayerComponent.OPTIONS lists them).
    OPTIONS: ClassVar[tuple[Option, ...]] = (
        Option("geofence", bool, False, "give a robot found stopped inside a no-go zone its "
               "shortest legal way out, as the percept geofence_exit(Robot, Zone, Lat, Lon) "
               "(geofence_trapped(Robot, Zone) when there is none)"),
        Option("geofence_kinds", list, ["no_go"], "the world model kinds of the zones no "
               "robot may stand in"),
        Option("geofence_margin_m", float, 1.0, "metres beyond the zone's outline the way "
               "out ends", Check.POSITIVE),
        Option("geofence_interval", float, 1.0, "seconds between two looks at a robot (and "
               "at the zones)", Check.POSITIVE),
        Option("geofence_stopped_mps", float, 0.05, "a robot slower than this (m/s) is "
               "stopped", Check.NON_NEGATIVE),
    )

    def __init__(self, world: WorldModelAccess, percept: PerceptPublisher, *,
                 kinds: tuple[str, ...] = ("no_go",), margin_m: float = 1.0,
                 interval: float = 1.0, stopped_mps: float = 0.05,
                 clock: Callable[[], float] = time.monotonic,
                 told: ToldPercepts | None = None,
                 settled: Callable[[], bool] = lambda: True) -> None:
        self.world, self.percept = world, percept
        self.kinds, self.margin_m = kinds, margin_m
        self.interval, self.stopped_mps = interval, stopped_mps
        self.clock = clock
        self.robots: dict[str, _Robot] = {}
        self._zones: list[_Zone] = []
        self._zones_read = -math.inf
        self.failing = False   # the last look could not read the world model
        #: what it told, durable when the store is a file; `settled`: every percept sent
        #: so far is acknowledged (withdrawn rows may then go)
        self.told = told or ToldPercepts(":memory:")
        self.settled = settled
        self._unsettled = False
        self._take_over()

    def _take_over(self) -> None:
        """Take over what a previous incarnation told (nothing in a fresh store)."""
        withdrawn = self.told.rows(Told.WITHDRAWN)
        for _robot, text in withdrawn:
            self.percept(text, op="remove")
        self._unsettled = bool(withdrawn)
        held = self.told.rows(Told.HELD)
        for robot, text in held:
            state = self.robots.setdefault(robot, _Robot())
            state.stale += (text,)
            state.finding = Finding.TRAPPED if text.startswith(TRAPPED) else Finding.EXIT
        if held or withdrawn:
            log.warning("geofence: taking over what the previous incarnation told: %d "
                        "percept(s) standing (%s), %d removal(s) sent again", len(held),
                        ", ".join(text for _, text in held) or "none", len(withdrawn))

    @classmethod
    def on(cls, section: Mapping[str, Any]) -> bool:
        """Whether `[datalayer]` turns the geofence on (a bad value: off; `mrss check`
        reports it)."""
        try:
            return bool(OptionValues(cls.OPTIONS, section, section="datalayer").flag("geofence"))
        except ConfigError:
            return False

    @classmethod
    def configured(cls, section: Mapping[str, Any], world: WorldModelAccess | None,
                   percept: PerceptPublisher, *, told: ToldPercepts | None = None,
                   settled: Callable[[], bool] = lambda: True) -> Geofence | None:
        """The geofence `[datalayer]` asks for, or None when it is off (or there is no
        world model to hold the zones: logged); `told`, `settled`: see `__init__`."""
        values = OptionValues(cls.OPTIONS, section, section="datalayer")
        if not values.flag("geofence"):   # a value not true or false: ConfigError
            return None
        if world is None:
            log.error("[datalayer] geofence is on but there is no world model to hold the "
                      "zones (world_model = \"none\"): no geofence")
            return None
        kinds = values["geofence_kinds"]
        return cls(world, percept, kinds=tuple(str(k) for k in kinds),
                   margin_m=values.number("geofence_margin_m"),
                   interval=values.number("geofence_interval"),
                   stopped_mps=values.number("geofence_stopped_mps"), told=told,
                   settled=settled)

    # -- one record ---------------------------------------------------------------------
    def observe(self, robot: str, record: Mapping[str, Any]) -> Finding | None:
        """Look at a telemetry record of `robot` (a position one, else nothing); what
        the look found, None when it was not time to look (or the world model did not
        answer: logged, and the next record looks again)."""
        try:
            found = self._look(robot, record)
        except Exception as exc:
            if not self.failing:
                log.warning("geofence: robots not checked until the world model answers "
                            "(robot %s: %s)", robot, exc)
            self.failing = True
            return None
        if self.failing and found is not None:
            self.failing = False
            log.warning("geofence: robots checked again")
        if self._unsettled and self.settled():   # the removals sent have arrived
            self.told.forget_withdrawn()
            self._unsettled = False
        return found

    def _look(self, robot: str, record: Mapping[str, Any]) -> Finding | None:
        if record.get("type", "position") != "position":
            return None
        lat, lon = record.get("lat"), record.get("lon")
        if not isinstance(lat, int | float) or not isinstance(lon, int | float):
            return None
        now = self.clock()
        state = self.robots.setdefault(robot, _Robot())
        speed = self._speed(state, record, float(lat), float(lon), now)
        if now - state.looked < self.interval:
            return None
        state.looked = now
        zones = self._inside(float(lat), float(lon))
        if not zones:
            self._tell(robot, state, Finding.OUTSIDE, "")
            return Finding.OUTSIDE
        if speed is None or speed > self.stopped_mps:
            return Finding.MOVING
        return self._stopped_inside(robot, state, float(lat), float(lon), zones[0])

    def _stopped_inside(self, robot: str, state: _Robot, lat: float, lon: float,
                        zone: _Zone) -> Finding:
        try:
            way = shortest_exit(lat, lon, [z.raw for z in self._zones], self.margin_m)
        except NoExit as exc:
            text = literal(TRAPPED, symbol(robot), symbol(zone.ident))
            if state.finding is not Finding.TRAPPED:
                log.error("geofence: robot %s is stopped inside no-go zone %r at %.6f,%.6f "
                          "and cannot leave it: %s; it stays where it is", robot, zone.ident,
                          lat, lon, exc)
            self._tell(robot, state, Finding.TRAPPED, text)
            return Finding.TRAPPED
        if way is None:   # on the outline itself: covered, yet no interior to leave
            self._tell(robot, state, Finding.OUTSIDE, "")
            return Finding.OUTSIDE
        text = literal(EXIT, symbol(robot), symbol(way.zone), round(way.lat, 7),
                       round(way.lon, 7))
        if text != state.percept:
            log.warning("geofence: robot %s is stopped inside no-go zone %r at %.6f,%.6f; "
                        "its shortest legal way out: %.7f,%.7f (%.1f m)", robot, way.zone,
                        lat, lon, way.lat, way.lon, way.distance_m)
        self._tell(robot, state, Finding.EXIT, text)
        return Finding.EXIT

    def _tell(self, robot: str, state: _Robot, finding: Finding, text: str) -> None:
        """Replace the percept the agent holds about `robot` by `text` ("" for none), and
        what a previous incarnation told about it. The store hears of each change first."""
        if text == state.percept and not state.stale:
            state.finding = finding
            return
        if text:
            self.told.mark(robot, text, Told.HELD)
        for old in (state.percept, *state.stale):
            if old and old != text:
                self.told.mark(robot, old, Told.WITHDRAWN)
                self.percept(old, op="remove")
                self._unsettled = True
        if text and text != state.percept:   # told again when only stale: no news to it
            self.percept(text)
        elif not text and state.finding in (Finding.EXIT, Finding.TRAPPED):
            log.info("geofence: robot %s is out of every no-go zone", robot)
        state.percept, state.finding, state.stale = text, finding, ()

    # -- what it reads ------------------------------------------------------------------
    def _speed(self, state: _Robot, record: Mapping[str, Any], lat: float, lon: float,
               now: float) -> float | None:
        """The robot's ground speed: the record's `speed`, else its `vx`/`vy`, else from
        its last fix (None at the first)."""
        previous, state.fix = state.fix, (lat, lon, now)
        speed = record.get("speed")
        if isinstance(speed, int | float) and not isinstance(speed, bool):
            return float(speed)
        vx, vy = record.get("vx"), record.get("vy")
        if isinstance(vx, int | float) and isinstance(vy, int | float):
            return math.hypot(vx, vy)
        if previous is None or now <= previous[2]:
            return None
        return distance_m(previous[0], previous[1], lat, lon) / (now - previous[2])

    def _inside(self, lat: float, lon: float) -> list[_Zone]:
        """The zones covering the point (the zones read at most every interval)."""
        now = self.clock()
        if now - self._zones_read >= self.interval:
            self._zones = [_Zone(str(z.get("id", "")), z, shape(z["geometry"]))
                           for kind in self.kinds for z in self.world.objects(kind)
                           if isinstance(z.get("geometry"), Mapping)
                           and z["geometry"].get("type") == "Polygon"]
            self._zones_read = now
        here = Point(lon, lat)
        return [z for z in self._zones if z.outline.covers(here)]
