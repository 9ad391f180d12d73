"""The invariants of a campaign, checked over its recorded history (pure: no I/O, no clock).

Each rule is one function `check_<rule>(history, bounds) -> list[Violation]`; `check`
runs them all. What each one relies on is stated here and in docs/chaos.md:

- ONE_TERMINAL: an action has at most one terminal state, in the journal (one terminal
  transition) and on the bus (one distinct terminal state, ignoring statuses of an RCL
  incarnation older than the one that published the terminal); and every action the
  reasoner requested reaches the journal, unless its requesting incarnation died within
  `latch` seconds of the request.
- NO_TRANSITION_AFTER_TERMINAL: no journal transition after the terminal one; no other
  state published for the uuid after its terminal status (a repeat of it is fine).
- LATCH_RELEASED: after the journal's terminal commit of an action at T, the reasoner
  incarnation that asked for it logs the latch's release (`action <uuid> ...`: the
  terminal status taken, the intention dropped, or the lease failing it) or dies, by
  T + `latch`. The observable is the reasoner's log line (bus `log.*` or the run's log).
- GOAL_HANDLED: every operator goal the broker accepted ends in one of: an action for
  it succeeded, a reply to the operator names it or the final mind says it failed (the
  project's `[operator.goals] failed` belief, which the dashboard shows), the operator
  cancelled it, an action for it is still open at the end, or the final mind still
  holds it (a belief of the project's `pending_beliefs` naming it). Otherwise it was
  dropped silently.
- NO_COMMAND_AFTER_CANCEL: no skill started for an action already terminal (the RCL's
  "already <terminal>; running dropped"), no skill abandoned still running ("ignored its
  interrupt"), an action the reasoner cancels is terminal within `cancel` s, every
  action of a goal the operator cancelled is terminal within `cancel` s and none is
  requested after the cancel, and an action of a dead reasoner incarnation is terminal
  within `cancel` s of the death, or adopted (a newer incarnation asks for the same
  name, robot and goal within that time).
- MODE_CONSISTENT: for each robot mode the operator switched (teleop), once the faults
  are over, the last accepted switch, the reasoner's belief (project's `mode_beliefs`),
  the RCL journal's flag and the robot's last telemetry of it agree.
- CONVERGED: within `converge` s of the last fault a probe finds every component
  running, every intention's action open in the journal and every open action waited
  on by an intention (`probe_problems`).
"""

from __future__ import annotations

import re
from collections import defaultdict
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any

from mrss.chaos.convergence import converged_after, probe_problems
from mrss.chaos.goals import GoalOutcome, goal_outcomes
from mrss.chaos.history import History, JournalAction, OperatorEvent
from mrss.chaos.views import (
    TERMINAL,
    accepted,
    death_times,
    end_of,
    last_mind,
    messages,
    reasoners,
    requests,
    statuses,
    terminal_at,
)

__all__ = ["Bounds", "GoalOutcome", "Invariant", "Verdict", "Violation", "check",
           "converged_after", "goal_outcomes", "probe_problems"]

STARTED_AFTER_TERMINAL = re.compile(
    r"action ([0-9a-f]{32}) is already (succeeded|failed|cancelled); running dropped")
ABANDONED_SKILL = re.compile(r"skill \d+ of action ([0-9a-f]{32}) ignored its interrupt")


class Invariant(StrEnum):
    ONE_TERMINAL = "one-terminal-state"
    NO_TRANSITION_AFTER_TERMINAL = "no-transition-after-terminal"
    LATCH_RELEASED = "latch-released"
    GOAL_HANDLED = "goal-handled"
    NO_COMMAND_AFTER_CANCEL = "no-command-after-cancel"
    MODE_CONSISTENT = "mode-consistent"
    CONVERGED = "converged"


@dataclass(frozen=True)
class Bounds:
    """Seconds: latch release, cancel/orphan stop, convergence after the last fault."""

    latch: float = 15.0
    cancel: float = 15.0
    converge: float = 60.0


@dataclass(frozen=True)
class Violation:
    invariant: Invariant
    subject: str
    evidence: tuple[str, ...]


@dataclass
class Verdict:
    violations: list[Violation] = field(default_factory=list)
    goals: dict[str, GoalOutcome] = field(default_factory=dict)
    acted_on: set[str] = field(default_factory=set)
    converged_after: float | None = None

    def of(self, invariant: Invariant) -> list[Violation]:
        return [v for v in self.violations if v.invariant is invariant]


def check(history: History, bounds: Bounds = Bounds()) -> Verdict:
    """Every invariant over `history`."""
    verdict = Verdict()
    verdict.goals, verdict.acted_on = goal_outcomes(history)
    verdict.converged_after = converged_after(history)
    for rule in (check_one_terminal, check_no_transition_after_terminal,
                 check_latch_released, check_goal_handled, check_no_command_after_cancel,
                 check_mode_consistent, check_converged):
        verdict.violations.extend(rule(history, bounds))
    return verdict


# -- the rules ------------------------------------------------------------------------------
def check_one_terminal(h: History, b: Bounds) -> list[Violation]:
    out: list[Violation] = []
    if h.journal is not None:
        ends: dict[str, list[str]] = defaultdict(list)
        for x in sorted(h.journal.transitions, key=lambda x: x.seq):
            if x.state in TERMINAL:
                ends[x.uuid].append(f"journal seq {x.seq} at {x.t:.1f}s: {x.state} "
                                    f"{x.reason!r}")
        out += [Violation(Invariant.ONE_TERMINAL, u, tuple(ev))
                for u, ev in ends.items() if len(ev) > 1]
    for uuid, seen in statuses(h).items():
        finals = [e for e in seen if e.body.get("state") in TERMINAL]
        top = max((e.inc for e in finals), default=0)
        states = {str(e.body["state"]) for e in finals if e.inc >= top}
        if len(states) > 1:
            out.append(Violation(Invariant.ONE_TERMINAL, uuid, tuple(
                f"bus at {e.t:.1f}s from {e.src} inc {e.inc}: {e.body['state']}"
                for e in finals)))
    if h.journal is not None and not h.journal.error:
        known = {a.uuid for a in h.journal.actions}
        deaths = death_times(h)
        for uuid, req in requests(h).items():
            if uuid in known or req.src not in reasoners(h) or req.t > h.journal.t - b.latch:
                continue
            died = deaths.get((req.src, req.inc))
            if died is not None and died <= req.t + b.latch:
                continue
            out.append(Violation(Invariant.ONE_TERMINAL, uuid, (
                f"requested at {req.t:.1f}s by {req.src} inc {req.inc}: "
                f"{req.body.get('literal')}", "never in the RCL journal")))
    return out


def check_no_transition_after_terminal(h: History, b: Bounds) -> list[Violation]:
    out: list[Violation] = []
    if h.journal is not None:
        by_uuid: dict[str, list[Any]] = defaultdict(list)
        for x in sorted(h.journal.transitions, key=lambda x: x.seq):
            by_uuid[x.uuid].append(x)
        for uuid, rows in by_uuid.items():
            first = next((i for i, x in enumerate(rows) if x.state in TERMINAL), None)
            later = [] if first is None else [x for x in rows[first + 1:]
                                              if x.state not in TERMINAL]
            if later:
                out.append(Violation(Invariant.NO_TRANSITION_AFTER_TERMINAL, uuid, tuple(
                    f"journal seq {x.seq} at {x.t:.1f}s: {x.state} {x.reason!r}"
                    for x in [rows[first]] + later)))  # type: ignore[index]
    for uuid, seen in statuses(h).items():
        final = next((e for e in seen if e.body.get("state") in TERMINAL), None)
        if final is None:
            continue
        after = [e for e in seen[seen.index(final) + 1:] if e.inc >= final.inc
                 and e.body.get("state") != final.body.get("state")]
        if after:
            out.append(Violation(Invariant.NO_TRANSITION_AFTER_TERMINAL, uuid, tuple(
                f"bus at {e.t:.1f}s from {e.src} inc {e.inc}: {e.body.get('state')} "
                f"{e.body.get('reason', '')!r}" for e in [final, *after])))
    return out


def check_latch_released(h: History, b: Bounds) -> list[Violation]:
    if h.journal is None:
        return []
    names = reasoners(h)
    lines = messages(h, names)
    deaths = death_times(h)
    ends = terminal_at(h)
    out: list[Violation] = []
    for action in h.journal.actions:
        ended = ends.get(action.uuid)
        if ended is None or action.requester not in names or ended[0] + b.latch > end_of(h):
            continue
        prefix = f"action {action.uuid} "
        released = [t for t, m in lines if m.startswith(prefix) and not m.endswith(" sent")]
        died = deaths.get((action.requester, action.requester_inc))
        if any(t <= ended[0] + b.latch for t in released) or (
                died is not None and died <= ended[0] + b.latch):
            continue
        out.append(Violation(Invariant.LATCH_RELEASED, action.uuid, (
            f"{action.name}({action.robot},{action.goal}) of {action.requester} "
            f"inc {action.requester_inc}", f"journal {ended[1]} at {ended[0]:.1f}s",
            f"release seen at {released[0]:.1f}s" if released else
            f"no release by {end_of(h):.1f}s, requester still alive")))
    return out


def check_goal_handled(h: History, b: Bounds) -> list[Violation]:
    outcomes, acted = goal_outcomes(h)
    out = []
    for step in accepted(h, "goal"):
        if outcomes.get(step.goal) is not GoalOutcome.DROPPED:
            continue
        mine = [a for a in (h.journal.actions if h.journal else []) if a.goal == step.goal]
        out.append(Violation(Invariant.GOAL_HANDLED, step.goal, (
            f"accepted by the broker at {step.t:.1f}s",
            "actions: " + (", ".join(f"{a.name} {a.state} ({a.reason})" for a in mine)
                           if mine else "none requested"),
            "no reply to the operator, not held by the agent at the end")))
    return out


def check_no_command_after_cancel(h: History, b: Bounds) -> list[Violation]:
    out: list[Violation] = []
    v = Invariant.NO_COMMAND_AFTER_CANCEL
    for t, m in messages(h, set(h.campaign.get("rcls") or ["rcl"])):
        for pattern, what in ((STARTED_AFTER_TERMINAL, "skills started for a terminal action"),
                              (ABANDONED_SKILL, "a skill ignored its interrupt")):
            found = pattern.search(m)
            if found:
                out.append(Violation(v, found.group(1), (f"{what} at {t:.1f}s: {m}",)))
    if h.journal is None:
        return out
    ends = terminal_at(h)
    end = end_of(h)
    by_uuid = {a.uuid: a for a in h.journal.actions}

    def late(a: JournalAction, since: float) -> str | None:
        """Why `a` still ran `cancel` s after `since` (None if it did not)."""
        ended = ends.get(a.uuid)
        if ended is not None and ended[0] <= since + b.cancel:
            return None
        if ended is None and end < since + b.cancel:
            return None  # undetermined: the campaign ended too soon after
        return (f"{ended[1]} only at {ended[0]:.1f}s" if ended else
                f"still {a.state} at the end ({end:.1f}s)")

    names = reasoners(h)
    for e in h.of_kind("action.control"):
        body = e.body
        if (e.src in names and body.get("command") == "cancel"
                and body.get("target_kind") == "action" and body.get("target") in by_uuid):
            action = by_uuid[str(body["target"])]
            why = late(action, e.t)
            if why:
                out.append(Violation(v, action.uuid, (
                    f"{e.src} cancelled {action.name}({action.robot},{action.goal}) at "
                    f"{e.t:.1f}s", why)))
    goals = accepted(h, "goal")
    for c in accepted(h, "cancel"):
        resent = min((g.t for g in goals if g.goal == c.goal and g.t > c.t),
                     default=float("inf"))
        for action in (a for a in h.journal.actions if a.goal == c.goal):
            if action.created > c.t + 1e-9:
                if action.created < resent:
                    out.append(Violation(v, action.uuid, (
                        f"operator cancelled goal {c.goal} at {c.t:.1f}s",
                        f"{action.name} requested for it at {action.created:.1f}s")))
                continue
            why = late(action, c.t)
            if why:
                out.append(Violation(v, action.uuid, (
                    f"operator cancelled goal {c.goal} at {c.t:.1f}s",
                    f"{action.name}({action.robot},{c.goal}) {why}")))
    deaths = death_times(h)
    for action in h.journal.actions:
        died = deaths.get((action.requester, action.requester_inc))
        if action.requester not in names or died is None or action.created > died:
            continue
        ended = ends.get(action.uuid)
        if ended is not None and ended[0] <= died:
            continue
        adopted = any(r.src == action.requester and r.inc > action.requester_inc
                      and died <= r.t <= died + b.cancel
                      and (r.body.get("name"), r.body.get("robot"), r.body.get("goal"))
                      == (action.name, action.robot, action.goal)
                      for r in requests(h).values())
        why = None if adopted else late(action, died)
        if why:
            out.append(Violation(v, action.uuid, (
                f"{action.name}({action.robot},{action.goal}) of {action.requester} inc "
                f"{action.requester_inc}, which died at {died:.1f}s", f"orphan {why}, "
                "not adopted by a newer incarnation")))
    return out


def mode_views(h: History, robot: str, mode: str) -> dict[str, bool | None]:
    """Whether `mode` is on for `robot` as the reasoner, the RCL and the robot see it."""
    pattern = str((h.campaign.get("mode_beliefs") or {}).get(mode, "")).format(robot=robot)
    mind = last_mind(h)
    reasoner = None if mind is None or not pattern else any(
        str(x).startswith(pattern) for x in mind.get("beliefs", []))
    rcl = None  # a robot the RCL was never switched for has no flag: not counted (the
    if h.journal is not None and not h.journal.error and mode == "teleop":  # wildfire
        rcl = h.journal.teleop.get(robot)  # agent switches with a skill, not ctl.teleop)
    robot_view = None
    for e in h.of_kind("robot.data"):
        data = e.body.get("data") or {}
        if e.body.get("robot") == robot and isinstance(data.get(mode), bool):
            robot_view = bool(data[mode])
    return {"reasoner": reasoner, "rcl": rcl, "robot": robot_view}


def check_mode_consistent(h: History, b: Bounds) -> list[Violation]:
    last: dict[tuple[str, str], OperatorEvent] = {}
    for step in accepted(h, "mode"):
        last[(step.robot, step.mode)] = step
    out = []
    settled = max(h.faults_ended_at, max((s.t for s in last.values()), default=0.0))
    if end_of(h) < settled + b.cancel:
        return []  # not enough calm after the last switch to judge
    for (robot, mode), step in sorted(last.items()):
        views = mode_views(h, robot, mode)
        wrong = {k: v for k, v in views.items() if v is not None and v != step.on}
        if wrong:
            out.append(Violation(Invariant.MODE_CONSISTENT, f"{robot} {mode}", (
                f"operator switched it {'on' if step.on else 'off'} at {step.t:.1f}s",
                *(f"{k} sees it {'on' if val else 'off'}" for k, val in wrong.items()))))
    return out


def check_converged(h: History, b: Bounds) -> list[Violation]:
    after = converged_after(h)
    if after is not None and after <= b.converge:
        return []
    start = h.faults_ended_at
    late = [p for p in h.probes if p.t >= start]
    evidence = [f"last fault over at {start:.1f}s"]
    if after is not None:
        evidence.append(f"converged only {after:.1f}s later")
    elif not late:
        evidence.append("no probe after the last fault"
                        + (f"; mrss supervise exited {h.end.get('exit_code')}"
                           if h.end.get("exit_code") is not None else ""))
    else:
        evidence.append(f"not converged at the last probe ({late[-1].t:.1f}s):")
        evidence += probe_problems(late[-1])[:10]
    return [Violation(Invariant.CONVERGED, "system", tuple(evidence))]
