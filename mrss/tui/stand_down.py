"""Stand-down by area from the dashboard: a shape drawn on the map, a form, a question.

A circle or polygon drawn on the map (R or Z) offers "stand down the robots inside"
beside the project's commands. Its form asks the mode (`hold`: they stop where they
are; `home`: they are sent home) and which robots (`all`, or capabilities such as
`uav`); the question names the robots the dashboard sees inside and what happens. It
goes to the RCL as `ctl.stand_down` (mrss.actors.rcl.stand_down), which decides from
each robot's own position which are held and says so (`fleet.stand_down`, shown as
a note and on the map). `U` lifts every active stand-down in one command
(`ctl.stand_down_lift`), after its own question. A circle is sent as a 48-gon.
"""

from __future__ import annotations

import logging
import math
import time
from typing import Any

from rich.text import Text
from shapely.geometry import Point, Polygon

from mrss.config.operator_commands import CommandSpec, FieldSpec, FieldType
from mrss.links.geo import offset
from mrss.messages import Command, StandDownMode, StandDownState
from mrss.tui.events import SendRequested
from mrss.tui.models.logfilter import LogEntry
from mrss.tui.models.robots import RobotsModel
from mrss.tui.operator import OperatorError

NAME = "stand down the robots inside"
CIRCLE_SIDES = 48
ALL = "all"


def spec(kind: FieldType) -> CommandSpec:
    """The form: the area as drawn (`kind`: circle or polygon), the mode, the robots."""
    return CommandSpec(
        name="stand_down", percept="", topic="", label="Stand down the robots inside",
        functor="ctl.stand_down", arity=1,
        fields=(FieldSpec("area", kind, label="area (drawn on the map)"),
                FieldSpec("mode", FieldType.CHOICE, default=StandDownMode.HOLD.value,
                          choices=tuple(m.value for m in StandDownMode),
                          label="hold: stop where they are; home: go home"),
                FieldSpec("robots", FieldType.TEXT, default=ALL,
                          label="which robots: all, or capabilities (uav, camera)")))


def ring(area: Any, kind: FieldType) -> list[list[float]]:
    """The closed GeoJSON ring ([lon, lat]) of the form's area value."""
    if kind is FieldType.CIRCLE:
        (lat, lon), radius = area["center"], float(area["radius"])
        points = [offset(lat, lon, radius * math.cos(a), radius * math.sin(a))
                  for a in (2 * math.pi * i / CIRCLE_SIDES for i in range(CIRCLE_SIDES))]
    else:
        points = [(float(p[0]), float(p[1])) for p in area]
    lonlat = [[p[1], p[0]] for p in points]
    return [*lonlat, lonlat[0]]


def inside(robots: RobotsModel, outline: list[list[float]]) -> list[str]:
    """The robots the dashboard sees inside the ring (by their last position)."""
    shape = Polygon(outline)
    found = []
    for name, view in sorted(robots.robots.items()):
        place = view.place()
        if place is not None and shape.intersects(Point(place[1], place[0])):
            found.append(name)
    return found


def request(payload: dict[str, Any], kind: FieldType, robots: RobotsModel) -> SendRequested:
    """The `ctl.stand_down` the form's payload makes, with its question."""
    outline = ring(payload["area"], kind)
    mode = StandDownMode(payload["mode"])
    words = [w.strip() for w in str(payload["robots"]).replace(",", " ").split()]
    capabilities = [] if words == [ALL] else [w for w in words if w]
    seen = inside(robots, outline)
    ident = f"sd-{time.strftime('%H%M%S')}"
    body = Command(command="stand_down", target=ident, args={
        "area": {"type": "Polygon", "coordinates": [outline]}, "mode": mode.value,
        "capabilities": capabilities, "robots": seen})
    which = "every robot" if not capabilities else f"robots with {', '.join(capabilities)}"
    does = ("stop where they are (a copter hovers)" if mode is StandDownMode.HOLD
            else "are sent home (copter RTL, ground robot back to base)")
    details = [f"{which} inside the area: their actions are suspended and they {does};",
               f"seen inside here: {', '.join(seen) or 'none'} (the RCL decides from each "
               "robot's own last position, and says which it held);",
               "new actions for them wait, tasks addressed to a role go to robots outside;",
               "U lifts it: they go on from where they were."]
    return SendRequested(body, f"stand-down {ident} ({mode.value}, {which})",
                         confirm=f"Stand down {which} in this area ({mode.value})?",
                         details=details)


def lift(active: dict[str, StandDownState]) -> SendRequested:
    """`U`: lift every active stand-down, after a question naming them."""
    if not active:
        raise OperatorError("no stand-down is active")
    details = [f"{s.ident} ({s.mode.value}): {', '.join(s.robots) or 'no robot'}"
               for s in active.values()]
    return SendRequested(Command(command="stand_down_lift", target=""),
                         f"lift {len(active)} stand-down(s)",
                         confirm="Lift every stand-down: the robots go on?",
                         details=[*details, "Their suspended actions resume from their "
                                  "progress; a robot sent home flies back to its work."])


def stand_down_line(state: StandDownState, ts: float) -> LogEntry:
    """The log pane's line for the RCL's word on a stand-down (made, refused, lifted)."""
    stamp = time.strftime("%H:%M:%S", time.localtime(ts))
    if not state.active and state.notes and state.notes[0].startswith("refused"):
        text, level = f"{state.ident} {state.notes[0]}", logging.WARNING
    elif not state.active:
        text = f"{state.ident} lifted: {', '.join(state.robots) or 'no robot'} go on"
        level = logging.INFO
    else:
        held = ", ".join(state.robots) or "no robot (none inside by their positions)"
        extra = f" ({'; '.join(state.notes)})" if state.notes else ""
        text, level = f"{state.ident} ({state.mode.value}): {held} held{extra}", logging.WARNING
    return LogEntry(Text.assemble((f"{stamp} ", "dim"), ("stand-down ", "bold red"), text),
                    level, "rcl")
