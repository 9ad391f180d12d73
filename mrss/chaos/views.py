"""Queries over a campaign history that several invariants share (pure)."""

from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass
from typing import Any

from mrss.chaos.history import BusEvent, History, JournalAction, OperatorEvent

TERMINAL = ("succeeded", "failed", "cancelled")
# How late a terminal status may reach the recorder after its journal commit (a bus
# proxy restarting, a frozen RCL between commit and publish): what the compaction
# watermark is stretched by when an action's bus status tells it was compacted.
STATUS_TRAVEL = 15.0


def reasoners(h: History) -> set[str]:
    names = h.campaign.get("reasoners") or []
    return {str(n) for n in names} or {"reasoner"}


def statuses(h: History) -> dict[str, list[BusEvent]]:
    out: dict[str, list[BusEvent]] = defaultdict(list)
    for e in h.of_kind("action.status"):
        out[str(e.body.get("uuid"))].append(e)
    return out


def requests(h: History) -> dict[str, BusEvent]:
    """The first request seen of each uuid (the reliable channel may repeat one)."""
    out: dict[str, BusEvent] = {}
    for e in h.of_kind("action.request"):
        out.setdefault(str(e.body.get("uuid")), e)
    return out


def terminal_at(h: History) -> dict[str, tuple[float, str]]:
    """uuid -> (time, state) of its first terminal transition in the journal; of an
    action compacted away (`compacted`), its first terminal status on the bus."""
    out: dict[str, tuple[float, str]] = {}
    if h.journal is not None:
        for x in sorted(h.journal.transitions, key=lambda x: x.seq):
            if x.state in TERMINAL:
                out.setdefault(x.uuid, (x.t, x.state))
    for uuid, ended in compacted(h).items():
        out.setdefault(uuid, ended)
    return out


def bus_terminal(h: History) -> dict[str, tuple[float, str]]:
    """uuid -> (time, state) of the first terminal status the bus showed of it."""
    out: dict[str, tuple[float, str]] = {}
    for uuid, seen in statuses(h).items():
        final = next((e for e in seen if e.body.get("state") in TERMINAL), None)
        if final is not None:
            out[uuid] = (final.t, str(final.body["state"]))
    return out


def compacted(h: History) -> dict[str, tuple[float, str]]:
    """The actions the journal's compaction dropped, judged by what the bus showed:
    uuid -> (time, state) of its first terminal status on the bus.

    An action is taken as compacted when the journal lacks it, the journal says its
    compaction dropped actions, and the bus showed it terminal by the watermark (no
    terminal action last updated before it is left; plus `STATUS_TRAVEL`), the
    earliest-ended first and no more of them than compaction dropped. Any other action
    the journal lacks was never journaled.
    """
    j = h.journal
    if j is None or j.error or j.compacted <= 0 or j.compacted_before is None:
        return {}
    known = {a.uuid for a in j.actions}
    ended = sorted((t, uuid, state) for uuid, (t, state) in bus_terminal(h).items()
                   if uuid not in known and t <= j.compacted_before + STATUS_TRAVEL)
    return {uuid: (t, state) for t, uuid, state in ended[:j.compacted]}


def not_compacted(h: History) -> tuple[str, ...]:
    """Why an action the journal lacks was not compacted away either (evidence; none when
    the journal never compacted)."""
    j = h.journal
    if j is None or j.compacted_before is None:
        return ()
    return (f"not compacted either: the journal's compaction dropped {j.compacted} actions "
            f"ended before {j.compacted_before:.1f}s, and {len(compacted(h))} the bus "
            "showed ended by then",)


def actions(h: History) -> list[JournalAction]:
    """The journal's actions, and those its compaction dropped as the bus showed them
    (`compacted`: their terminal state; name, robot, goal and requester from their
    request, or their status; created when first seen)."""
    out = list(h.journal.actions) if h.journal is not None else []
    gone = compacted(h)
    if not gone:
        return out
    reqs = requests(h)
    seen = statuses(h)
    for uuid, (_t, state) in gone.items():
        first = reqs.get(uuid) or seen[uuid][0]
        body = first.body
        out.append(JournalAction(
            uuid, str(body.get("name", "")), str(body.get("robot", "")),
            str(body.get("goal", "")), state, "compacted away (the bus showed it)",
            first.src if uuid in reqs else "", first.inc if uuid in reqs else 0, first.t))
    return out


def death_times(h: History) -> dict[tuple[str, int], float]:
    """(component, incarnation) -> when it was seen dead: its exit event, or the first
    message of a newer incarnation of that component."""
    out: dict[tuple[str, int], float] = {}
    seen: dict[str, set[int]] = defaultdict(set)
    for e in h.bus:
        if e.kind == "sup.event" and e.body.get("event") == "exit":
            inc = (e.body.get("detail") or {}).get("inc")
            if isinstance(inc, int):
                out.setdefault((str(e.body.get("child")), inc), e.t)
        if e.inc > 0 and e.src:
            for old in [i for i in seen[e.src] if i < e.inc]:
                out.setdefault((e.src, old), e.t)
            seen[e.src].add(e.inc)
    return out


def messages(h: History, components: set[str]) -> list[tuple[float, str]]:
    """Log messages of `components`, from the bus and from the run's log file."""
    out = [(e.t, str(e.body.get("message", ""))) for e in h.of_kind("log.record")
           if e.body.get("component") in components]
    out += [(x.t, x.message) for x in h.loglines if x.component in components]
    return sorted(out)


def accepted(h: History, intent: str) -> list[OperatorEvent]:
    return [o for o in h.operator if o.ok and o.intent == intent]


def last_mind(h: History) -> dict[str, Any] | None:
    minds = [p.mind for p in h.probes if p.mind is not None]
    return minds[-1] if minds else None


def end_of(h: History) -> float:
    """When the campaign stopped looking (the journal's read, else the end record)."""
    return h.journal.t if h.journal is not None else float(h.end.get("t", 0.0))


@dataclass(frozen=True)
class Section:
    """A critical section of an action's skill as its statuses showed it (`critical`):
    opened at `opened`, closed at `closed` (None: still open when the history ends)."""

    uuid: str
    name: str
    bound: float
    opened: float
    closed: float | None

    def covers(self, t: float) -> bool:
        return self.opened <= t and (self.closed is None or t <= self.closed)


def critical_sections(h: History) -> list[Section]:
    """Every critical section the action statuses show, in order of opening: one opens
    with a status naming it and closes with the next status naming none (or another),
    a terminal one included."""
    out: list[Section] = []
    for uuid, seen in statuses(h).items():
        current: tuple[str, float, float] | None = None
        for e in seen:
            name = str(e.body.get("critical") or "")
            if current is not None and name != current[0]:
                out.append(Section(uuid, current[0], current[1], current[2], e.t))
                current = None
            if name and current is None:
                current = (name, float(e.body.get("critical_bound") or 0.0), e.t)
        if current is not None:
            out.append(Section(uuid, current[0], current[1], current[2], None))
    return sorted(out, key=lambda s: s.opened)
