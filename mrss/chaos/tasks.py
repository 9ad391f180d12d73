"""The invariants of tasks addressed to a role, over a campaign history (pure: no I/O).

A task is an action addressed to a role: its request carries a role, or the RCL sent a
`TaskAllocation` (`action.allocation`) for it. Its life on the bus is its allocations
(WAITING, AWARDED naming the winner) and its action's statuses (each names the robot
the action is on, or none while it waits again). Messages of an RCL incarnation older
than one already heard are a dead incarnation's late words and are ignored.

- NEVER_TWO_HOLDERS: at no time does a task have two holders. A robot holds a task from
  its award (or the first status of the action on it, after a restart that carried a
  recorded award out) until the task is released from it: a status of the action on no
  robot (PENDING "reassigning: ..."), a terminal status, or an award that says it was
  reassigned from that robot (the release's own status may be lost on the bus; the
  journal's "reassigning" transition counts as well). A violation is an award to a
  robot, or a status of the action on a robot, while another robot holds the task; or
  a second award to the robot that holds it (an award is decided once: after a restart
  a journaled award is carried out, not decided again).
- AWARD_BOUNDED: a task that waits while a capable robot can take it is awarded within
  the bound (mrss.chaos.task_bound: link loss + allocation + margin, stretched by each
  stall of the RCL or the bus in the wait, and each restart of the RCL, the bus proxy or
  everything (a fork server kill) in it or begun up to a restart's time before it). A
  task waits from its request, from the release of its holder and, when its holder is
  lost for good (a `robot_loss` fault), from that loss (the RCL learns of it only after
  the link's timeout, which the bound covers), until its award or its end. A robot can
  take it when it has every capability the task asks for (the campaign record's robots),
  its last `robot.state` says available with its link up and not in teleop, no action is
  on it (by the statuses, the awards and the journal's ends) and it was not lost for
  good. A violation is a wait during which such a robot stayed so for longer than the
  bound. The history holds no batteries: a task whose last WAITING before the deadline
  says `battery` (every capable robot would come home below its reserve) is excused, on
  the allocator's word.

Both read only the bus (and the journal's transitions when it was read); a campaign
that awarded no task leaves them vacuous, never holding.
"""

from __future__ import annotations

import re
from collections import defaultdict
from collections.abc import Callable
from dataclasses import dataclass, field

from mrss.chaos.history import BusEvent, History
from mrss.chaos.task_bound import AwardBound
from mrss.chaos.verdict import Bounds, Invariant, Ruling, Violation
from mrss.chaos.views import TERMINAL, death_times, end_of, requests, terminal_at

ALLOCATION = "action.allocation"
STATUS = "action.status"
ROBOT_LOSS = "robot_loss"
STALLS = ("hang", "blackout", "disk_full")  # faults that hold a process up for a while
REASSIGNED_FROM = re.compile(r"reassigned from (\S+) \(lost\)")
REASSIGNING = "reassigning"
CLOCK_SLACK = 0.5  # s between the journal's wall clock and the recorder's, moved together
EVIDENCE = 6  # lines of evidence kept per task


@dataclass
class Life:
    """One task as the bus showed it: its events in order, and what they mean."""

    uuid: str
    opened: float
    capabilities: frozenset[str]
    events: list[BusEvent] = field(default_factory=list)
    holders: list[tuple[str, float, float | None]] = field(default_factory=list)
    waits: list[tuple[float, float, str]] = field(default_factory=list)  # from, to, how
    awards: int = 0
    clashes: list[str] = field(default_factory=list)


def rcl_names(h: History) -> set[str]:
    return {str(n) for n in h.campaign.get("rcls") or []} or {"rcl"}


def live(h: History, kinds: tuple[str, ...]) -> list[BusEvent]:
    """The bus events of `kinds` from the RCLs, without a dead incarnation's late ones."""
    newest: dict[str, int] = {}
    out = []
    names = rcl_names(h)
    for e in h.bus:
        if e.src in names:
            if e.inc < newest.get(e.src, 0):
                continue
            newest[e.src] = e.inc
        if e.kind in kinds:
            out.append(e)
    return out


def losses(h: History) -> dict[str, float]:
    """robot -> when a `robot_loss` took it away for good."""
    out: dict[str, float] = {}
    for f in h.faults:
        if f.ok and f.kind == ROBOT_LOSS:
            out.setdefault(f.target, f.t)
    return out


def lives(h: History) -> dict[str, Life]:
    """Every task of the history, walked (holders, waits, clashes of two holders)."""
    reqs = requests(h)
    found: dict[str, Life] = {}
    for e in live(h, (ALLOCATION, STATUS)):
        uuid = str(e.body.get("uuid"))
        if uuid not in found:
            req = reqs.get(uuid)
            role = req.body.get("role") if req is not None else None
            if e.kind != ALLOCATION and not role:
                continue  # an action addressed to a robot by name
            caps = role.get("capabilities") if isinstance(role, dict) else None
            found[uuid] = Life(uuid, req.t if req is not None else e.t,
                               frozenset(str(c) for c in caps) if isinstance(caps, list)
                               else frozenset())
        found[uuid].events.append(e)
    for uuid, req in reqs.items():  # a task never awarded nor said waiting
        role = req.body.get("role")
        if role and uuid not in found:
            caps = role.get("capabilities") if isinstance(role, dict) else None
            found[uuid] = Life(uuid, req.t, frozenset(str(c) for c in caps)
                               if isinstance(caps, list) else frozenset())
    releases = _journal_releases(h)
    lost = losses(h)
    ends = terminal_at(h)
    for life in found.values():
        _walk(life, releases.get(life.uuid, []), lost, ends.get(life.uuid), end_of(h))
    return found


def _journal_releases(h: History) -> dict[str, list[float]]:
    out: dict[str, list[float]] = defaultdict(list)
    if h.journal is not None:
        for x in h.journal.transitions:
            if x.state == "pending" and x.reason.startswith(REASSIGNING):
                out[x.uuid].append(x.t)
    return out


def _walk(life: Life, releases: list[float], lost: dict[str, float],
          ended: tuple[float, str] | None, end: float) -> None:
    holder, since = "", 0.0
    wait_from: float | None = life.opened
    stop = min(ended[0], end) if ended is not None else end

    def release(t: float) -> None:
        nonlocal holder, wait_from
        if holder:
            life.holders.append((holder, since, t))
            gone = lost.get(holder)
            wait_from = gone if gone is not None and since <= gone <= t else t
        holder = ""

    def take(robot: str, t: float, how: str) -> None:
        nonlocal holder, since, wait_from
        if wait_from is not None:
            life.waits.append((wait_from, t, how))
            wait_from = None
        holder, since = robot, t

    for e in life.events:
        body = e.body
        if e.kind == ALLOCATION:
            if body.get("state") != "awarded":
                continue
            robot = str(body.get("robot") or "")
            life.awards += 1
            found = REASSIGNED_FROM.match(str(body.get("why") or ""))
            if holder and holder != robot:
                freed = (found is not None and found.group(1) == holder) or any(
                    since - CLOCK_SLACK <= t <= e.t + CLOCK_SLACK for t in releases)
                if not freed:
                    life.clashes.append(f"awarded to {robot} at {e.t:.1f}s while {holder} "
                                        f"held it (since {since:.1f}s)")
                release(e.t)
            elif holder == robot:  # decided again: a journaled award is only carried out
                life.clashes.append(f"awarded to {robot} again at {e.t:.1f}s while it held "
                                    f"it (since {since:.1f}s)")
            if holder != robot:
                take(robot, e.t, f"awarded to {robot}")
            continue
        state, robot = str(body.get("state")), str(body.get("robot") or "")
        if state in TERMINAL:
            release(e.t)
            if wait_from is not None and wait_from < e.t:
                life.waits.append((wait_from, e.t, f"{state} while it waited"))
            wait_from = None
            break
        if not robot:
            release(e.t)
            continue
        if holder and holder != robot:
            if not any(since - CLOCK_SLACK <= t <= e.t + CLOCK_SLACK for t in releases):
                life.clashes.append(f"{state} on {robot} at {e.t:.1f}s while {holder} "
                                    f"held it (since {since:.1f}s)")
            release(e.t)
        if holder != robot:
            take(robot, e.t, f"{state} on {robot}")
    if holder:
        life.holders.append((holder, since, None))
        gone = lost.get(holder)
        if gone is not None and since <= gone < stop:
            wait_from = gone  # its holder is gone for good: it waits from the loss
    if wait_from is not None and wait_from < stop:
        life.waits.append((wait_from, stop, "ended while it waited" if ended is not None
                           and ended[0] <= end else "still waiting at the end"))


# -- never two holders -------------------------------------------------------------------------
def check_never_two_holders(h: History, b: Bounds) -> Ruling:
    found = lives(h)
    out = [Violation(Invariant.NEVER_TWO_HOLDERS, life.uuid, tuple(
        [_named(h, life), *life.clashes[:EVIDENCE]]))
        for life in found.values() if life.clashes]
    return Ruling(out, sum(1 for life in found.values() if life.awards))


def _named(h: History, life: Life) -> str:
    req = requests(h).get(life.uuid)
    literal = req.body.get("literal") if req is not None else ""
    return f"task {literal or life.uuid} ({', '.join(sorted(life.capabilities)) or '?'})"


# -- awarded within the bound ------------------------------------------------------------------
def check_award_bounded(h: History, b: Bounds) -> Ruling:
    found = lives(h)
    if not found:
        return Ruling()
    robots = h.campaign.get("robots")
    bound = AwardBound.of_record(h.campaign.get("award_bound"))
    if not isinstance(robots, dict) or (bound is None and b.award <= 0):
        return Ruling(checked=0, unknown="the campaign record names no robots' capabilities "
                      "or award bound (a history from before the task invariants)")
    base = b.award if b.award > 0 or bound is None else bound.base
    capable = {str(r): frozenset(str(c) for c in caps) for r, caps in robots.items()
               if isinstance(caps, list)}
    ready = ready_times(h, set(capable))
    stretch = _stretches(h, bound)
    out: list[Violation] = []
    judged = 0
    for life in sorted(found.values(), key=lambda x: x.opened):
        for start, stop, how in life.waits:
            limit = base + stretch(start, stop)
            able = [r for r, caps in sorted(capable.items()) if life.capabilities <= caps]
            spans = [(r, a, z) for r in able for a, z in ready.get(r, [])
                     if a < stop and z > start]
            if not spans:
                continue
            judged += 1
            late = [(r, max(a, start), min(z, stop)) for r, a, z in spans
                    if min(z, stop) - max(a, start) > limit]
            if late and not _battery(life, min(a for _r, a, _z in late) + limit):
                r, a, z = min(late, key=lambda x: x[1])
                out.append(Violation(Invariant.AWARD_BOUNDED, life.uuid, (
                    _named(h, life), f"waiting from {start:.1f}s",
                    f"{r} could take it from {a:.1f}s to {z:.1f}s "
                    "(capable, available, link up, holding no action)",
                    f"{how} at {stop:.1f}s", f"bound {limit:.1f}s")))
                break
    return Ruling(out, judged)


def _battery(life: Life, deadline: float) -> bool:
    """Whether the task's last WAITING before the deadline says `battery`."""
    said = [e for e in life.events if e.kind == ALLOCATION and e.t <= deadline
            and e.body.get("state") == "waiting"]
    return bool(said) and said[-1].body.get("wait") == "battery"


def _stretches(h: History, bound: AwardBound | None) -> Callable[[float, float], float]:
    """(start, stop) -> seconds the bound grows by: the stalls of the RCL or the bus and
    the restarts of the RCL that fall in that wait."""
    stalls = set(bound.stalls) if bound is not None else set()
    restart = bound.restart if bound is not None else 0.0
    held = [(f.t, f.t + f.duration) for f in h.faults
            if f.ok and f.kind in STALLS and (f.target in stalls or f.kind == "blackout")]
    names = rcl_names(h)
    # restarts: the RCL's deaths as seen, the bus proxy's kills, the fork server's (all)
    deaths = [t for (src, _inc), t in death_times(h).items() if src in names]
    deaths += [f.t for f in h.faults if f.ok and (
        f.kind == "forkserver" or (f.kind == "kill" and f.target in stalls
                                   and f.target not in names))]

    def stretch(start: float, stop: float) -> float:
        """A restart that began up to `restart` s before the wait still holds it up."""
        return (sum(z - a for a, z in held if a < stop and z > start)
                + restart * sum(1 for t in deaths if start - restart <= t <= stop))
    return stretch


def ready_times(h: History, robots: set[str]) -> dict[str, list[tuple[float, float]]]:
    """robot -> the spans of time it could take a task: available, link up, not in
    teleop, no action on it, not lost for good (the module's rules)."""
    lost = losses(h)
    names = rcl_names(h)
    state: dict[str, tuple[bool, bool]] = {}  # robot -> (available and up, teleop)
    on: dict[str, str] = {}  # uuid -> the robot its action is on now
    marks: list[tuple[float, int, str, str, str]] = []  # (t, order, what, uuid/robot, robot)
    for n, e in enumerate(h.bus):
        if e.kind == "robot.state" and e.src in names:
            marks.append((e.t, n, "state", str(e.body.get("robot")), ""))
        elif e.kind in (STATUS, ALLOCATION):
            marks.append((e.t, n, e.kind, str(e.body.get("uuid")), ""))
    for uuid, (t, _state) in terminal_at(h).items():
        marks.append((t, len(h.bus), "end", uuid, ""))
    for robot, t in lost.items():
        marks.append((t, -1, "lost", robot, ""))
    bodies = {n: e for n, e in enumerate(h.bus)}
    spans: dict[str, list[tuple[float, float]]] = defaultdict(list)
    since: dict[str, float] = {}
    gone: set[str] = set()
    for t, n, what, key, _ in sorted(marks, key=lambda m: (m[0], m[1])):
        if what == "state":
            body = bodies[n].body
            attrs = body.get("attributes") or {}
            teleop = bool(attrs.get("teleop")) if "teleop" in attrs else \
                state.get(key, (False, False))[1]
            state[key] = (bool(body.get("available")) and body.get("link", "up") == "up",
                          teleop)
        elif what == "lost":
            gone.add(key)
        elif what == "end":
            on.pop(key, None)
        else:
            body = bodies[n].body
            robot = str(body.get("robot") or "")
            if what == ALLOCATION:
                if body.get("state") == "awarded" and robot:
                    on[key] = robot
            elif str(body.get("state")) in TERMINAL or not robot:
                on.pop(key, None)
            else:
                on[key] = robot
        busy = set(on.values())
        for robot in robots:
            can = robot in state and state[robot][0] and not state[robot][1] \
                and robot not in busy and robot not in gone
            if can and robot not in since:
                since[robot] = t
            elif not can and robot in since:
                spans[robot].append((since.pop(robot), t))
    end = end_of(h)
    for robot, t in since.items():
        spans[robot].append((t, end))
    return dict(spans)
