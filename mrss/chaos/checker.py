"""The invariants of a campaign, checked over its recorded history (pure: no I/O, no clock).

Each rule is one function `check_<rule>(history, bounds) -> Ruling`: its violations, how
many subjects it judged, and why it could not judge when the history lacks what it needs
(`mrss.chaos.verdict` turns that into holds / fails / incomplete / vacuous); `check` runs
them all. What each one relies on is stated here and in docs/chaos.md:

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
  holds it (a belief of the project's `pending_beliefs` naming it; none holds one when
  the project declares none). Otherwise it was dropped silently.
- NO_COMMAND_AFTER_CANCEL: no skill started for an action already terminal (the RCL's
  "already <terminal>; running dropped"), no skill abandoned still running ("ignored its
  interrupt"), an action the reasoner cancels is terminal within `cancel` s, every
  action of a goal the operator cancelled is terminal within `cancel` s and none is
  requested after the cancel, and an action of a dead reasoner incarnation is terminal
  within `cancel` s of the death, or adopted (a newer incarnation asks for the same
  name, robot and goal within that time). A cancel that arrives while a skill of the
  action is inside a critical section (`Skill.critical`, shown by its statuses) is
  deferred by design: its `cancel` s count from the section's end, or from its
  declared bound when it was held longer (which critical-bounded reports).
- MODE_CONSISTENT: for each robot mode the operator switched (teleop), once the faults
  are over, the last accepted switch, the reasoner's belief (project's `mode_beliefs`),
  the RCL journal's flag and the robot's last telemetry of it agree. Undetermined
  (incomplete) when the history ends less than `cancel` s after the later of the last
  fault and the last switch.
- CRITICAL_BOUNDED: no critical section is held longer than its declared bound (plus
  `critical_slack` s for the statuses' travel); one still open at the end counts until
  then. A pre-emption or suspension waiting for a section is no violation.
- CONVERGED: within `converge` s of the last fault a probe finds every component
  running, every intention's action open in the journal and every open action waited
  on by an intention (`probe_problems`). Incomplete when no probe came after the faults;
  vacuous when no fault was injected (a system that is not running still fails it).
- NO_ROBOT_STUCK and HEALED (mrss.chaos.recovery): no action of a skill with a progress
  bound runs longer than it without news; after the faults the last probe finds the
  robots as available as before the first fault (but those lost for good), and the
  system whole.
- NEVER_TWO_HOLDERS and AWARD_BOUNDED (mrss.chaos.tasks): no task addressed to a role
  is held by two robots at once; a task that waits while a capable robot can take it
  is awarded within the bound derived from the project (mrss.chaos.task_bound).

A rule that needs the journal (or the run's log) and finds it missing is incomplete; it
still reports what it could see without it, when that is a violation whatever the rest
says (two terminal states on the bus), and nothing that the missing part could refute.
"""

from __future__ import annotations

import re
from collections import defaultdict
from typing import Any

from mrss.chaos.convergence import converged_after, probe_problems
from mrss.chaos.goals import GoalOutcome, goal_outcomes
from mrss.chaos.history import History, JournalAction
from mrss.chaos.modes import check_mode_consistent
from mrss.chaos.recovery import check_healed, check_no_robot_stuck
from mrss.chaos.tasks import check_award_bounded, check_never_two_holders
from mrss.chaos.verdict import (
    Bounds,
    Invariant,
    Judgement,
    Outcome,
    Ruling,
    Verdict,
    Violation,
    journal_gap,
    log_gap,
    missing,
)
from mrss.chaos.views import (
    TERMINAL,
    Section,
    accepted,
    actions,
    compacted,
    critical_sections,
    death_times,
    end_of,
    messages,
    not_compacted,
    reasoners,
    requests,
    statuses,
    terminal_at,
)

__all__ = ["Bounds", "GoalOutcome", "Invariant", "Judgement", "Outcome", "Ruling", "Verdict",
           "Violation", "check", "converged_after", "goal_outcomes", "probe_problems"]

STARTED_AFTER_TERMINAL = re.compile(
    r"action ([0-9a-f]{32}) is already (succeeded|failed|cancelled); running dropped")
ABANDONED_SKILL = re.compile(r"skill \d+ of action ([0-9a-f]{32}) ignored its interrupt")


DEFAULT_BOUNDS = Bounds()


def check(history: History, bounds: Bounds = DEFAULT_BOUNDS) -> Verdict:
    """Every invariant over `history`, and what the history lacks to be complete."""
    verdict = Verdict(missing=missing(history))
    verdict.goals, verdict.acted_on = goal_outcomes(history)
    verdict.converged_after = converged_after(history)
    for invariant, rule in ((Invariant.ONE_TERMINAL, check_one_terminal),
                            (Invariant.NO_TRANSITION_AFTER_TERMINAL,
                             check_no_transition_after_terminal),
                            (Invariant.LATCH_RELEASED, check_latch_released),
                            (Invariant.GOAL_HANDLED, check_goal_handled),
                            (Invariant.NO_COMMAND_AFTER_CANCEL, check_no_command_after_cancel),
                            (Invariant.MODE_CONSISTENT, check_mode_consistent),
                            (Invariant.CONVERGED, check_converged),
                            (Invariant.NO_ROBOT_STUCK, check_no_robot_stuck),
                            (Invariant.HEALED, check_healed),
                            (Invariant.CRITICAL_BOUNDED, check_critical_bounded),
                            (Invariant.NEVER_TWO_HOLDERS, check_never_two_holders),
                            (Invariant.AWARD_BOUNDED, check_award_bounded)):
        verdict.rulings[invariant] = rule(history, bounds)
    return verdict


# -- the rules ------------------------------------------------------------------------------
def check_one_terminal(h: History, b: Bounds) -> Ruling:
    out: list[Violation] = []
    subjects = set(statuses(h)) | set(requests(h))
    if h.journal is not None:
        subjects |= {a.uuid for a in h.journal.actions}
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
        # those compacted away are judged by their terminal status on the bus
        known = {a.uuid for a in h.journal.actions} | set(compacted(h))
        deaths = death_times(h)
        for uuid, req in requests(h).items():
            if uuid in known or req.src not in reasoners(h) or req.t > h.journal.t - b.latch:
                continue
            died = deaths.get((req.src, req.inc))
            if died is not None and died <= req.t + b.latch:
                continue
            out.append(Violation(Invariant.ONE_TERMINAL, uuid, (
                f"requested at {req.t:.1f}s by {req.src} inc {req.inc}: "
                f"{req.body.get('literal')}", "never in the RCL journal", *not_compacted(h))))
    return Ruling(out, len(subjects), journal_gap(h))


def check_no_transition_after_terminal(h: History, b: Bounds) -> Ruling:
    out: list[Violation] = []
    subjects = {u for u, s in statuses(h).items() if any(e.body.get("state") in TERMINAL
                                                         for e in s)}
    if h.journal is not None:
        subjects |= {a.uuid for a in h.journal.actions}
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
    return Ruling(out, len(subjects), journal_gap(h))


def check_latch_released(h: History, b: Bounds) -> Ruling:
    gap = journal_gap(h) or log_gap(h)
    if h.journal is None or gap:
        return Ruling(unknown=gap)  # an unread log shows no release: nothing to assert
    names = reasoners(h)
    lines = messages(h, names)
    deaths = death_times(h)
    ends = terminal_at(h)
    out: list[Violation] = []
    judged = 0
    gone, where = compacted(h), ("journal", "bus (compacted away)")  # judged by the bus
    for action in actions(h):
        ended = ends.get(action.uuid)
        if ended is None or action.requester not in names or ended[0] + b.latch > end_of(h):
            continue
        judged += 1
        prefix = f"action {action.uuid} "
        released = [t for t, m in lines if m.startswith(prefix) and not m.endswith(" sent")]
        died = deaths.get((action.requester, action.requester_inc))
        if any(t <= ended[0] + b.latch for t in released) or (
                died is not None and died <= ended[0] + b.latch):
            continue
        out.append(Violation(Invariant.LATCH_RELEASED, action.uuid, (
            f"{action.name}({action.robot},{action.goal}) of {action.requester} "
            f"inc {action.requester_inc}", f"{where[action.uuid in gone]} {ended[1]} at "
            f"{ended[0]:.1f}s",
            f"release seen at {released[0]:.1f}s" if released else
            f"no release by {end_of(h):.1f}s, requester still alive")))
    return Ruling(out, judged)


def check_goal_handled(h: History, b: Bounds) -> Ruling:
    goals = accepted(h, "goal")
    if journal_gap(h):  # an action of a "dropped" goal may have succeeded: assert nothing
        return Ruling(checked=len(goals), unknown=journal_gap(h))
    outcomes, acted = goal_outcomes(h)
    out = []
    for step in goals:
        if outcomes.get(step.goal) is not GoalOutcome.DROPPED:
            continue
        mine = [a for a in actions(h) if a.goal == step.goal]
        out.append(Violation(Invariant.GOAL_HANDLED, step.goal, (
            f"accepted by the broker at {step.t:.1f}s",
            "actions: " + (", ".join(f"{a.name} {a.state} ({a.reason})" for a in mine)
                           if mine else "none requested"),
            "no reply to the operator, not held by the agent at the end")))
    return Ruling(out, len({g.goal for g in goals}))


def check_no_command_after_cancel(h: History, b: Bounds) -> Ruling:
    out: list[Violation] = []
    v = Invariant.NO_COMMAND_AFTER_CANCEL
    for t, m in messages(h, set(h.campaign.get("rcls") or ["rcl"])):
        for pattern, what in ((STARTED_AFTER_TERMINAL, "skills started for a terminal action"),
                              (ABANDONED_SKILL, "a skill ignored its interrupt")):
            found = pattern.search(m)
            if found:
                out.append(Violation(v, found.group(1), (f"{what} at {t:.1f}s: {m}",)))
    if h.journal is None or h.journal.error:
        return Ruling(out, 0, journal_gap(h))
    ends = terminal_at(h)
    end = end_of(h)
    known = actions(h)  # with those compacted away, as the bus showed them
    by_uuid = {a.uuid: a for a in known}
    sections: dict[str, list[Section]] = defaultdict(list)
    for section in critical_sections(h):
        sections[section.uuid].append(section)

    def late(a: JournalAction, since: float) -> str | None:
        """Why `a` still ran `cancel` s after `since` (None if it did not); a critical
        section open at `since` defers it to the section's end (at most its bound)."""
        for section in sections.get(a.uuid, []):
            if section.covers(since):
                limit = section.opened + section.bound
                since = max(since, min(limit, section.closed if section.closed is not None
                                       else limit))
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
        for action in (a for a in known if a.goal == c.goal):
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
    for action in known:
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
    return Ruling(out, len(known), log_gap(h))  # the log: skills after the end


def check_critical_bounded(h: History, b: Bounds) -> Ruling:
    found = critical_sections(h)
    out = []
    for s in found:
        held = (s.closed if s.closed is not None else end_of(h)) - s.opened
        if held > s.bound + b.critical_slack:
            out.append(Violation(Invariant.CRITICAL_BOUNDED, s.uuid, (
                f"critical section {s.name!r} opened at {s.opened:.1f}s, bound {s.bound:g}s",
                f"closed at {s.closed:.1f}s" if s.closed is not None
                else f"still open at the end ({end_of(h):.1f}s)",
                f"held {held:.1f}s")))
    return Ruling(out, len(found))


def check_converged(h: History, b: Bounds) -> Ruling:
    start = h.faults_ended_at
    late = [p for p in h.probes if p.t >= start]
    if not late:  # the campaign always probes after the faults: the history is cut short
        return Ruling(unknown=f"no probe after the last fault ({start:.1f}s)" + (
            f"; mrss supervise exited {h.end.get('exit_code')}"
            if h.end.get("exit_code") is not None else ""))
    disturbed = int(any(f.ok for f in h.faults))  # else nothing to converge from: vacuous
    after = converged_after(h)
    if after is not None and after <= b.converge:
        return Ruling(checked=disturbed)
    evidence = [f"last fault over at {start:.1f}s"]
    if after is not None:
        evidence.append(f"converged only {after:.1f}s later")
    else:
        evidence.append(f"not converged at the last probe ({late[-1].t:.1f}s):")
        evidence += probe_problems(late[-1])[:10]
    return Ruling([Violation(Invariant.CONVERGED, "system", tuple(evidence))], disturbed)
