"""MODE_CONSISTENT: once the faults are over, a robot mode the operator switched is seen
alike by the reasoner (its `mode_beliefs`), the RCL (the journal's flag) and the robot (its
last telemetry of it); see mrss.chaos.checker and docs/chaos.md (pure)."""

from __future__ import annotations

from mrss.chaos.history import History, OperatorEvent
from mrss.chaos.verdict import Bounds, Invariant, Ruling, Violation, journal_gap
from mrss.chaos.views import accepted, end_of, last_mind


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


def check_mode_consistent(h: History, b: Bounds) -> Ruling:
    last: dict[tuple[str, str], OperatorEvent] = {}
    for step in accepted(h, "mode"):
        last[(step.robot, step.mode)] = step
    out = []
    if not last:
        return Ruling()
    settled = max(h.faults_ended_at, max(s.t for s in last.values()))
    if end_of(h) < settled + b.cancel:
        return Ruling(checked=len(last), unknown=(
            f"undetermined: the history ends at {end_of(h):.1f}s, "
            f"{max(0.0, end_of(h) - settled):.1f}s after the last fault or switch "
            f"({settled:.1f}s); judging needs {b.cancel:g}s of calm"))
    if journal_gap(h):
        return Ruling(checked=len(last), unknown=journal_gap(h))  # the RCL's view
    for (robot, mode), step in sorted(last.items()):
        views = mode_views(h, robot, mode)
        wrong = {k: v for k, v in views.items() if v is not None and v != step.on}
        if wrong:
            out.append(Violation(Invariant.MODE_CONSISTENT, f"{robot} {mode}", (
                f"operator switched it {'on' if step.on else 'off'} at {step.t:.1f}s",
                *(f"{k} sees it {'on' if val else 'off'}" for k, val in wrong.items()))))
    return Ruling(out, len(last))
