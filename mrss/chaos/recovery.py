"""The invariants of getting over faults: no robot stuck, and healed to the same state (pure).

- NO_ROBOT_STUCK: an action whose skills declare a progress bound (`Skill.progress_bound`;
  the RCL puts the action's bound B on its RUNNING status, field `progress_bound`, 0 or
  absent: none) never stays RUNNING longer than B s without news: a status
  of it on the bus (a progress update is one) or a journal transition. Silence runs
  from the last news to the next one, or to the end of the history while it is still
  running. A violation names the action, its robot and the silence.
- HEALED: after the last fault is over and the system settled, the last probe finds it
  as it was before the first fault: every robot that was available with its link up
  (its last `robot.state` before the first fault) is so again (its last one at all),
  but a robot taken away for good (`robot_loss`), which must stay away,
  and the system is whole (`probe_problems` of the last probe: every component
  running, every open action waited on by an intention, every waited-on action open:
  no orphan, every action has an outcome or an owner).

HEALED needs a probe after the faults: a history without one is incomplete.
"""

from __future__ import annotations

from collections import defaultdict

from mrss.chaos.convergence import probe_problems
from mrss.chaos.history import History
from mrss.chaos.verdict import Invariant, Ruling, Violation
from mrss.chaos.views import TERMINAL, end_of, statuses


def progress_bounds(h: History) -> dict[str, tuple[str, float]]:
    """uuid -> (action name, bound) for each action a RUNNING status gave a progress bound
    (the tightest, if its runs gave several)."""
    out: dict[str, tuple[str, float]] = {}
    for uuid, seen in statuses(h).items():
        for e in seen:
            bound = e.body.get("progress_bound") or 0
            if e.body.get("state") != "running" or not isinstance(bound, int | float) \
                    or bound <= 0:
                continue
            name = str(e.body.get("name") or "?")
            if uuid not in out or bound < out[uuid][1]:
                out[uuid] = (name, float(bound))
    return out


def check_no_robot_stuck(h: History, b: object = None) -> Ruling:
    bounds = progress_bounds(h)
    news: dict[str, list[tuple[float, str]]] = defaultdict(list)
    robots: dict[str, str] = {}
    for uuid, seen in statuses(h).items():
        for e in seen:
            news[uuid].append((e.t, str(e.body.get("state"))))
            robots.setdefault(uuid, str(e.body.get("robot", "")))
    if h.journal is not None:
        for x in h.journal.transitions:
            news[x.uuid].append((x.t, x.state))
        for a in h.journal.actions:
            robots[a.uuid] = a.robot
    end = end_of(h)
    out: list[Violation] = []
    judged = 0
    for uuid, (name, bound) in sorted(bounds.items()):
        timeline = sorted(news.get(uuid, []))
        if not any(state == "running" for _, state in timeline):
            continue
        judged += 1
        silences: list[tuple[float, float, str]] = []  # (silence, since, until what)
        running_since: float | None = None
        for t, state in timeline:
            if running_since is not None:
                silences.append((t - running_since, running_since, f"{state} at {t:.1f}s"))
            running_since = t if state == "running" else None
            if state in TERMINAL:
                break
        if running_since is not None:
            silences.append((end - running_since, running_since,
                             f"still running at the end ({end:.1f}s)"))
        worst = max(silences, default=None)
        if worst is not None and worst[0] > bound:
            out.append(Violation(Invariant.NO_ROBOT_STUCK, uuid, (
                f"robot {robots.get(uuid) or '?'}, action {name} (progress bound {bound:g}s)",
                f"running without news from {worst[1]:.1f}s for {worst[0]:.1f}s: "
                f"next {worst[2]}")))
    return Ruling(out, judged)


def robot_states(h: History, before: float | None = None) -> dict[str, tuple[bool, str]]:
    """robot -> (available, link) from its last `robot.state` (before `before`, if given)."""
    out: dict[str, tuple[bool, str]] = {}
    for e in h.of_kind("robot.state"):
        if before is None or e.t < before:
            out[str(e.body.get("robot"))] = (bool(e.body.get("available")),
                                             str(e.body.get("link", "up")))
    return out


def check_healed(h: History, b: object = None) -> Ruling:
    injected = [f for f in h.faults if f.ok]
    if not injected:
        return Ruling()  # nothing to heal from: vacuous
    start = h.faults_ended_at
    late = [p for p in h.probes if p.t >= start]
    if not late:
        return Ruling(unknown=f"no probe after the last fault ({start:.1f}s)")
    last = late[-1]
    first_fault = min(f.t for f in injected)
    before = robot_states(h, first_fault)
    after = robot_states(h)
    lost = {f.target for f in injected if f.kind == "robot_loss"}
    evidence = []
    for robot, (available, link) in sorted(before.items()):
        if robot in lost:
            continue
        if available and link == "up" and after.get(robot) != (True, "up"):
            now = after[robot]
            evidence.append(f"robot {robot}: available, link up before the first fault "
                            f"({first_fault:.1f}s); at the end "
                            f"{'available' if now[0] else 'unavailable'}, link {now[1]}")
    evidence += [f"at the last probe ({last.t:.1f}s): {p}" for p in probe_problems(last)]
    if not evidence:
        return Ruling(checked=1)
    return Ruling([Violation(Invariant.HEALED, "system", tuple(evidence))], 1)
