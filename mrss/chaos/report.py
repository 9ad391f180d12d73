"""The campaign report: a summary of the history and the checker's verdict, as data and text.

`summary` gathers what a person qualifying a deployment asks first (pure, from the
history and the verdict): faults by kind, restarts by component, actions by final
state, the operator's goals (accepted, acted on, reported failed, and each one's
outcome), the time to converge, each invariant's judgement (holds, fails, incomplete,
vacuous) with its violations, what the history lacks, and the verdict. `text` renders
it; `mrss chaos --json` prints the summary itself.
"""

from __future__ import annotations

from collections import Counter
from typing import Any

from mrss.chaos.checker import GoalOutcome, Invariant, Judgement, Outcome, Verdict
from mrss.chaos.history import History

EVIDENCE_SHOWN = 5  # violations shown per invariant in the text


def summary(history: History, verdict: Verdict, source: str = "") -> dict[str, Any]:
    """Everything the report says, as plain data."""
    c = history.campaign
    injected = Counter(f.kind for f in history.faults if f.ok)
    failed = Counter(f.kind for f in history.faults if not f.ok)
    restarts = _restarts(history)
    gave_up = sorted({str(e.body.get("child")) for e in history.of_kind("sup.event")
                      if e.body.get("event") == "give_up"})
    actions = Counter(a.state for a in history.journal.actions) if history.journal else {}
    ops = [o for o in history.operator]
    goals = [o for o in ops if o.intent == "goal"]
    outcomes = Counter(verdict.goals.values())
    return {
        "project": c.get("project", "?"),
        "seed": c.get("seed"),
        "history": source,
        "faults_planned": len(c.get("planned", [])),
        "faults_injected": dict(sorted(injected.items())),
        "faults_not_injected": dict(sorted(failed.items())),
        "fault_errors": sorted({f.error for f in history.faults if not f.ok})[:10],
        "faults_skipped": dict(sorted((c.get("skipped") or {}).items())),
        "relays": dict(history.end.get("relays") or {}),
        "restarts": restarts,
        "gave_up": gave_up,
        "exit_code": history.end.get("exit_code"),
        "actions": dict(sorted(actions.items())),
        "journal_error": history.journal.error if history.journal else "no journal record",
        "journal_compacted": history.journal.compacted if history.journal else 0,
        "goals_sent": len(goals),
        "goals_accepted": sum(1 for g in goals if g.ok),
        "goals_acted_on": len(verdict.acted_on),
        "goals_reported_failed": outcomes.get(GoalOutcome.REPORTED, 0),
        "goal_outcomes": {o.value: outcomes.get(o, 0) for o in GoalOutcome},
        "operator_steps": dict(sorted(Counter(o.intent for o in ops if o.ok).items())),
        "faults_ended": round(history.faults_ended_at, 1),
        "converged_after": None if verdict.converged_after is None
        else round(verdict.converged_after, 1),
        "invariants": {i.value: {"judgement": verdict.judgement(i).value,
                                 "violations": len(verdict.of(i)), "why": verdict.why(i)}
                       for i in Invariant},
        "violations": [{"invariant": v.invariant.value, "subject": v.subject,
                        "evidence": list(v.evidence)} for v in verdict.violations],
        "missing": list(verdict.missing),
        "verdict": verdict.outcome.value,
    }


def _restarts(history: History) -> dict[str, int]:
    """Restarts per component from the `sup.restart` events, children of other supervisors
    (the RCL's robot actors) as `supervisor:child`; for the root's children, its own count
    in the last tree a probe got wins (the bus may miss events, e.g. the bus proxy's)."""
    root = history.campaign.get("project")
    counts = Counter(
        str(e.body.get("child")) if e.body.get("supervisor") in ("", None, root)
        else f"{e.body.get('supervisor')}:{e.body.get('child')}"
        for e in history.of_kind("sup.event") if e.body.get("event") == "restart")
    trees = [p.tree for p in history.probes if p.tree is not None]
    for child in (trees[-1].get("children", []) or []) if trees else []:
        counts[str(child.get("id"))] = int(child.get("restarts", 0))
    return {k: v for k, v in sorted(counts.items()) if v}


def text(s: dict[str, Any]) -> str:
    """The report as a person reads it."""
    def counts(d: dict[str, int]) -> str:
        return ", ".join(f"{k} {v}" for k, v in d.items()) or "none"

    injected = sum(s["faults_injected"].values())
    lines = [
        f"mrss chaos {s['project']}: seed {s['seed']}, {s['faults_planned']} faults planned,"
        f" {injected} injected",
        f"  history          {s['history']}",
        f"  faults           {counts(s['faults_injected'])}",
    ]
    if s["faults_not_injected"]:
        lines.append(f"  not injected     {counts(s['faults_not_injected'])}: "
                     + "; ".join(s["fault_errors"][:3]))
    for kind, why in s["faults_skipped"].items():
        lines.append(f"  skipped          {kind}: {why}")
    for robot, seen in s["relays"].items():
        lines.append(f"  relay {robot:<10} {counts(seen)}")
    lines += [
        f"  restarts         {counts(s['restarts'])}"
        + (f"; gave up: {', '.join(s['gave_up'])}" if s["gave_up"] else ""),
        f"  actions          {counts(s['actions'])}"
        + (f"; {s['journal_compacted']} compacted away" if s["journal_compacted"] else "")
        + (f" ({s['journal_error']})" if s["journal_error"] else ""),
        f"  operator goals   {s['goals_accepted']} accepted of {s['goals_sent']} sent, "
        f"{s['goals_acted_on']} acted on, {s['goals_reported_failed']} reported failed",
        f"  goal outcomes    {counts({k: v for k, v in s['goal_outcomes'].items() if v})}",
        f"  operator steps   {counts(s['operator_steps'])}",
        f"  faults over at   {s['faults_ended']}s; "
        + (f"converged {s['converged_after']}s later" if s["converged_after"] is not None
           else "never converged"),
        f"  exit code        {s['exit_code']}",
        "invariants:",
    ]
    for name, judged in s["invariants"].items():
        lines.append(f"  {name:<30} {_judgement(judged)}")
    shown: Counter[str] = Counter()
    for v in s["violations"]:
        shown[v["invariant"]] += 1
        if shown[v["invariant"]] > EVIDENCE_SHOWN:
            continue
        lines.append(f"- {v['invariant']} {v['subject']}")
        lines += [f"    {e}" for e in v["evidence"]]
    hidden = {k: n - EVIDENCE_SHOWN for k, n in shown.items() if n > EVIDENCE_SHOWN}
    if hidden:
        lines.append(f"  (not shown: {counts(hidden)}; all of them: --json)")
    if s["missing"]:
        lines.append("the history is incomplete:")
        lines += [f"  - {m}" for m in s["missing"]]
    lines.append(f"verdict: {_verdict(s)} (exit {Outcome(s['verdict']).exit_code})")
    return "\n".join(lines)


def _judgement(judged: dict[str, Any]) -> str:
    j = Judgement(judged["judgement"])
    if j is Judgement.FAILS:
        return f"FAILS: {judged['violations']} violation(s)"
    if j is Judgement.HOLDS:
        return "holds"
    return f"{j.value.upper() if j is Judgement.INCOMPLETE else j.value}: {judged['why']}"


def _verdict(s: dict[str, Any]) -> str:
    """The last line: the outcome and what decided it."""
    judged = {k: Judgement(v["judgement"]) for k, v in s["invariants"].items()}
    count = Counter(judged.values())
    outcome = Outcome(s["verdict"])
    if outcome is Outcome.FAILS:
        if count[Judgement.FAILS]:
            return (f"FAILS: {count[Judgement.FAILS]} invariant(s) violated, "
                    f"{len(s['violations'])} violation(s)")
        return "FAILS: every invariant is vacuous, the campaign checked nothing"
    if outcome is Outcome.INCOMPLETE:
        why = []
        if s["missing"]:
            why.append(f"the history lacks {len(s['missing'])} thing(s) above")
        if count[Judgement.INCOMPLETE]:
            why.append(f"{count[Judgement.INCOMPLETE]} invariant(s) could not be judged")
        return "INCOMPLETE: " + " and ".join(why) + "; no violation found, none ruled out"
    vacuous = [k for k, j in judged.items() if j is Judgement.VACUOUS]
    return "holds: every invariant holds" + (
        f" ({len(vacuous)} vacuous: {', '.join(vacuous)})" if vacuous else "")
