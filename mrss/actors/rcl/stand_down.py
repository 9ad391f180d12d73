"""Stand-down by area: the operator stops, or sends home, the robots inside an area.

One object of the RCL core (mrss/actors/rcl/core.py). Rules:
- `ctl.stand_down` (a Command; `target` its id, `args`: `area` a GeoJSON Polygon
  [lon, lat], `mode` hold or home (`StandDownMode`), `capabilities` what a robot must
  have to be concerned ([]: every robot), `robots` the robots the operator saw inside,
  the dashboard's picture) is checked first: a bad area, mode or capability, or an id
  in use, is refused, with the reason, as an inactive `StandDownState`, and nothing
  changes.
- Which robots: the RCL decides from each concerned robot's own last position (its
  link's, the one the bids use), never from the dashboard's picture: a robot inside the
  area or on its edge. A robot the operator named that is outside by that position, or
  has none yet, is not held and is said (`notes`). The set is fixed when the stand-down
  is made: a robot entering the area later is not concerned.
- Journaled before it acts, and kept until lifted, across RCL and whole-system restarts
  (a stand-down is a safety measure, like a decommission).
- A held robot: each of its open actions is suspended by the operator (reason
  `stand-down ID (MODE)`), each new action for it starts suspended, and it makes no bid
  for a task addressed to a role (unavailable: `stood down (ID)`), so its role tasks
  wait for it or go to a robot outside. Mode home: its link is also told to send it
  home once its skills have stopped (`going_home.GoHome`).
- `ctl.stand_down_lift` (target an id, or "" for every active one) lifts it, journaled:
  each robot held by no other active stand-down has its actions resumed (from their
  progress) and bids again.
- Each change goes out as a `StandDownState` (level-triggered: again on a snapshot).
"""

from __future__ import annotations

import difflib
import json
import logging
import re
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass

from shapely.geometry import Point

from mrss.actors.rcl import lifecycle as lc
from mrss.actors.rcl.going_home import GoHome
from mrss.actors.rcl.journal import ActionJournal
from mrss.actors.rcl.open_actions import OpenActions, Routes
from mrss.errors import MrssError
from mrss.messages import Command, JsonValue, Message, StandDownMode, StandDownState
from mrss.world.geometry import Geometry, GeometryType

log = logging.getLogger("mrss.rcl.stand_down")

STAND_DOWN, LIFT = "stand_down", "stand_down_lift"  # the commands (ctl.<command>)
IDENT = re.compile(r"^[A-Za-z0-9_.-]{1,64}$")
Place = tuple[float, float]  # (lat, lon)


class StandDownError(MrssError):
    """A stand-down refused: what is wrong with it."""


@dataclass(frozen=True)
class StandDown:
    """One stand-down as made: its area, mode, who is concerned and who is held."""

    ident: str
    mode: StandDownMode
    area: Geometry
    capabilities: tuple[str, ...] = ()
    robots: tuple[str, ...] = ()  # held
    notes: tuple[str, ...] = ()
    by: str = ""

    def state(self, active: bool) -> StandDownState:
        return StandDownState(ident=self.ident, mode=self.mode, active=active,
                              area=self.area.to_json(), capabilities=list(self.capabilities),
                              robots=list(self.robots), notes=list(self.notes), by=self.by)

    def to_json(self) -> str:
        return json.dumps({"mode": self.mode.value, "area": self.area.to_json(),
                           "capabilities": list(self.capabilities), "robots": list(self.robots),
                           "notes": list(self.notes), "by": self.by}, sort_keys=True)

    @classmethod
    def from_json(cls, ident: str, text: str) -> StandDown:
        body = json.loads(text)
        return cls(ident, StandDownMode(body["mode"]), Geometry.from_json(body["area"]),
                   tuple(body["capabilities"]), tuple(body["robots"]), tuple(body["notes"]),
                   str(body.get("by", "")))


def reason(ident: str, mode: StandDownMode) -> str:
    """Why a held robot's actions are suspended (their status says it)."""
    return f"stand-down {ident} ({mode.value})"


class StandDowns:
    """The active stand-downs and the robots they hold (the rules of the module)."""

    def __init__(self, robots: Iterable[str], capabilities: Mapping[str, frozenset[str]],
                 where: Callable[[str], Place | None], journal: ActionJournal,
                 actions: OpenActions, routes: Routes,
                 publish: Callable[[Message], object]) -> None:
        self.robots = tuple(robots)
        self.capabilities = capabilities
        self._where, self.journal, self.actions, self.routes = where, journal, actions, routes
        self.publish = publish
        self.on_change: Callable[[], None] = lambda: None  # the allocator's kick
        self._active: dict[str, StandDown] = {}

    # -- what the core asks --------------------------------------------------------------
    def holder(self, robot: str) -> StandDown | None:
        """The oldest active stand-down that holds `robot`, or None."""
        return next((s for s in self._active.values() if robot in s.robots), None)

    def cause_for(self, robot: str) -> lc.Suspend | None:
        """How a new action for `robot` starts: suspended by the operator, or None."""
        held = self.holder(robot)
        return None if held is None else lc.Suspend(lc.SuspendCause.OPERATOR,
                                                     reason(held.ident, held.mode))

    def not_bidding(self) -> dict[str, str]:
        """robot -> why it makes no bid now (held)."""
        return {r: f"stood down ({s.ident})" for s in self._active.values() for r in s.robots}

    def restore(self) -> None:
        """The journal's active stand-downs (an RCL restart); their robots' actions come
        back suspended from the journal, new ones start suspended."""
        for ident, text in sorted(self.journal.stand_downs().items()):
            try:
                self._active[ident] = StandDown.from_json(ident, text)
            except (ValueError, KeyError, TypeError, MrssError) as exc:
                log.error("journaled stand-down %s unreadable, dropped: %r", ident, exc)
                self.journal.drop_stand_down(ident)

    def announce(self) -> None:
        for held in self._active.values():
            self.publish(held.state(True))

    # -- the operator's commands ---------------------------------------------------------
    def command(self, body: Command, by: str) -> None:
        """`ctl.stand_down` or `ctl.stand_down_lift`; a refusal goes back as a state."""
        if body.command == LIFT:
            self.lift(body.target)
            return
        try:
            made = self._make(body, by)
        except StandDownError as exc:
            log.warning("stand-down %r refused: %s", body.target, exc)
            self.publish(StandDownState(ident=body.target or "?", mode=StandDownMode.HOLD,
                                        active=False, notes=[f"refused: {exc}"], by=by))
            return
        self.journal.save_stand_down(made.ident, made.to_json())
        self._active[made.ident] = made
        log.warning("stand-down %s (%s) by %s: %s held%s", made.ident, made.mode.value,
                    by or "the local operator", ", ".join(made.robots) or "no robot",
                    "; " + "; ".join(made.notes) if made.notes else "")
        suspend = lc.Suspend(lc.SuspendCause.OPERATOR, reason(made.ident, made.mode))
        for robot in made.robots:
            for uuid in self.actions.of_robot(robot):
                self.routes.control_one(uuid, suspend)
            if made.mode is StandDownMode.HOME:
                self.routes.tell(robot, GoHome(made.ident))
        self.publish(made.state(True))
        self.on_change()

    def lift(self, ident: str) -> None:
        """Lift one stand-down ("": every one); robots no longer held go on."""
        lifted = [s for i, s in self._active.items() if not ident or i == ident]
        if not lifted:
            log.warning("stand-down lift %r: no such active stand-down (active: %s)", ident,
                        ", ".join(self._active) or "none")
            return
        for held in lifted:
            self.journal.drop_stand_down(held.ident)
            del self._active[held.ident]
            log.warning("stand-down %s lifted", held.ident)
        freed = sorted({r for s in lifted for r in s.robots if self.holder(r) is None})
        for robot in freed:
            for uuid in self.actions.of_robot(robot):
                self.routes.control_one(uuid, lc.Resume(lc.SuspendCause.OPERATOR))
        for held in lifted:
            self.publish(held.state(False))
        self.on_change()

    def _make(self, body: Command, by: str) -> StandDown:
        ident, args = body.target, body.args
        if not IDENT.match(ident):
            raise StandDownError(f"id {ident!r}: expected 1 to 64 letters, digits, _ . -")
        if ident in self._active:
            raise StandDownError(f"id {ident!r} is active already (lift it first)")
        try:
            mode = StandDownMode(args.get("mode", StandDownMode.HOLD.value))
        except ValueError:
            raise StandDownError(f"mode {args.get('mode')!r}: expected one of "
                                 f"{', '.join(m.value for m in StandDownMode)}") from None
        try:
            area = Geometry.from_json(args.get("area"))
        except (ValueError, TypeError) as exc:
            raise StandDownError(f"area: {exc}") from None
        if area.type is not GeometryType.POLYGON:
            raise StandDownError(f"area: expected a Polygon, not a {area.type.value}")
        wanted = _strings(args.get("capabilities", []), "capabilities")
        known = sorted(set().union(*self.capabilities.values())) if self.capabilities else []
        for capability in wanted:
            if capability not in known:
                close = difflib.get_close_matches(capability, known, n=1)
                hint = f" (did you mean {close[0]!r}?)" if close else ""
                raise StandDownError(f"no robot has capability {capability!r}{hint}; "
                                     f"known: {', '.join(known) or 'none'}")
        seen = set(_strings(args.get("robots", []), "robots"))
        shape, held, notes = area.shape, [], []
        for robot in self.robots:
            if not set(wanted) <= self.capabilities.get(robot, frozenset()):
                if robot in seen:
                    notes.append(f"{robot} lacks {', '.join(wanted)}: not concerned")
                continue
            place = self._where(robot)
            if place is None:
                if robot in seen:
                    notes.append(f"{robot} has reported no position yet: not held")
                continue
            if shape.intersects(Point(place[1], place[0])):
                held.append(robot)
            elif robot in seen:
                notes.append(f"{robot} is outside by its last position "
                             f"({place[0]:.6f}, {place[1]:.6f}): not held")
        for robot in sorted(seen - set(self.robots)):
            notes.append(f"{robot} is not a robot of this RCL")
        return StandDown(ident, mode, area, tuple(wanted), tuple(held), tuple(notes), by)


def _strings(value: JsonValue, key: str) -> list[str]:
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise StandDownError(f"{key}: expected a list of names, not {value!r}")
    return list(value)
