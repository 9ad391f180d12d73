"""The verdict of a campaign: closed sets for each invariant and for the whole, and what
makes a history complete enough to be judged (pure: no I/O, no clock).

Each rule of `mrss.chaos.checker` gives a `Ruling`: its violations, how many subjects it
judged (actions, goals, mode switches, the system) and, when the history lacks what it
needs, why it could not judge. From that, each invariant is one `Judgement`:

- FAILS: a violation was found (a violation is one whatever else is missing);
- INCOMPLETE: the history lacks what the rule needs (no journal, the run's log unread,
  too little calm after the last mode switch): it could not be judged;
- VACUOUS: the rule had nothing to check (no action, no accepted goal, no mode switch);
- HOLDS: it judged something and nothing broke it.

A history is complete (`missing` is empty) when it has the campaign record, the RCL
journal read without error, the end record, every planned fault injected, at least one
operator goal the broker accepted, and the run's log read without error (the `log`
record). The campaign's `Outcome` is the first that applies:

1. FAILS: an invariant fails, or every invariant is vacuous (the campaign checked nothing);
2. INCOMPLETE: the history is incomplete, or an invariant could not be judged;
3. HOLDS: every invariant holds or is vacuous, on a complete history.

`Outcome.exit_code` is the exit code of `mrss chaos` (2 and 3 are the command's own: bad
usage or an unreadable history, and a campaign that could not run).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum

from mrss.chaos.goals import GoalOutcome
from mrss.chaos.history import History
from mrss.chaos.views import accepted


@dataclass(frozen=True)
class Bounds:
    """Seconds: latch release, cancel/orphan stop, convergence after the last fault, and
    a task's award (0: the bound the campaign derived from the project, recorded in its
    campaign record; mrss.chaos.task_bound)."""

    latch: float = 15.0
    cancel: float = 15.0
    converge: float = 60.0
    critical_slack: float = 1.0
    award: float = 0.0


class Invariant(StrEnum):
    ONE_TERMINAL = "one-terminal-state"
    NO_TRANSITION_AFTER_TERMINAL = "no-transition-after-terminal"
    LATCH_RELEASED = "latch-released"
    GOAL_HANDLED = "goal-handled"
    NO_COMMAND_AFTER_CANCEL = "no-command-after-cancel"
    MODE_CONSISTENT = "mode-consistent"
    CONVERGED = "converged"
    NO_ROBOT_STUCK = "no-robot-stuck"
    HEALED = "heals-to-same-state"
    CRITICAL_BOUNDED = "critical-bounded"
    NEVER_TWO_HOLDERS = "never-two-holders"
    AWARD_BOUNDED = "award-bounded"


#: What an invariant had none of when it is vacuous (the report says it).
NOTHING_TO_CHECK = {
    Invariant.ONE_TERMINAL: "no action requested, published or journaled",
    Invariant.NO_TRANSITION_AFTER_TERMINAL: "no action journaled or ended on the bus",
    Invariant.LATCH_RELEASED: "no action of a reasoner ended early enough to judge",
    Invariant.GOAL_HANDLED: "no operator goal accepted",
    Invariant.NO_COMMAND_AFTER_CANCEL: "no action journaled",
    Invariant.MODE_CONSISTENT: "no mode switch accepted",
    Invariant.CONVERGED: "no fault injected, nothing to converge from",
    Invariant.NO_ROBOT_STUCK: "no action of a skill with a progress bound ran",
    Invariant.HEALED: "no fault injected, nothing to heal from",
    Invariant.CRITICAL_BOUNDED: "no skill entered a critical section",
    Invariant.NEVER_TWO_HOLDERS: "no task addressed to a role was awarded",
    Invariant.AWARD_BOUNDED: "no task addressed to a role waited while a capable robot "
                             "could take it",
}


class Judgement(StrEnum):
    """What became of one invariant over a history."""

    HOLDS = "holds"
    FAILS = "fails"
    INCOMPLETE = "incomplete"
    VACUOUS = "vacuous"


class Outcome(StrEnum):
    """The campaign's verdict, and the exit code `mrss chaos` gives it."""

    HOLDS = "holds"
    FAILS = "fails"
    INCOMPLETE = "incomplete"

    @property
    def exit_code(self) -> int:
        return {Outcome.HOLDS: 0, Outcome.FAILS: 1, Outcome.INCOMPLETE: 4}[self]


@dataclass(frozen=True)
class Violation:
    invariant: Invariant
    subject: str
    evidence: tuple[str, ...]


@dataclass(frozen=True)
class Ruling:
    """What one rule found: violations, subjects judged, why it could not judge (if so)."""

    violations: list[Violation] = field(default_factory=list)
    checked: int = 0
    unknown: str = ""

    @property
    def judgement(self) -> Judgement:
        if self.violations:
            return Judgement.FAILS
        if self.unknown:
            return Judgement.INCOMPLETE
        return Judgement.VACUOUS if self.checked == 0 else Judgement.HOLDS


@dataclass
class Verdict:
    """Every invariant's ruling, what the history lacks, and the campaign's outcome."""

    rulings: dict[Invariant, Ruling] = field(default_factory=dict)
    missing: list[str] = field(default_factory=list)
    goals: dict[str, GoalOutcome] = field(default_factory=dict)
    acted_on: set[str] = field(default_factory=set)
    converged_after: float | None = None

    @property
    def violations(self) -> list[Violation]:
        return [v for i in Invariant for v in self.of(i)]

    def of(self, invariant: Invariant) -> list[Violation]:
        ruling = self.rulings.get(invariant)
        return list(ruling.violations) if ruling is not None else []

    def judgement(self, invariant: Invariant) -> Judgement:
        ruling = self.rulings.get(invariant)
        return ruling.judgement if ruling is not None else Judgement.INCOMPLETE

    def why(self, invariant: Invariant) -> str:
        """Why an invariant could not be judged, or what it had none of ("" otherwise)."""
        judgement = self.judgement(invariant)
        if judgement is Judgement.INCOMPLETE:
            ruling = self.rulings.get(invariant)
            return ruling.unknown if ruling is not None else "not checked"
        return NOTHING_TO_CHECK[invariant] if judgement is Judgement.VACUOUS else ""

    @property
    def outcome(self) -> Outcome:
        judged = [self.judgement(i) for i in Invariant]
        if Judgement.FAILS in judged or all(j is Judgement.VACUOUS for j in judged):
            return Outcome.FAILS
        if self.missing or Judgement.INCOMPLETE in judged:
            return Outcome.INCOMPLETE
        return Outcome.HOLDS


def missing(h: History) -> list[str]:
    """What `h` lacks to be a complete history (empty: it is complete)."""
    out = []
    if not h.campaign:
        out.append("no campaign record")
    if journal_gap(h):
        out.append(journal_gap(h))
    if not h.end:
        out.append("no end record: the campaign did not finish")
    planned = len(h.campaign.get("planned") or [])
    injected = sum(1 for f in h.faults if f.ok)
    if injected != planned:
        out.append(f"{injected} of the {planned} planned faults injected")
    if not accepted(h, "goal"):
        out.append("no operator goal accepted by the broker" + (
            "" if h.campaign.get("operator", True) else " (the project declares no "
            f"operator traffic: projects/{h.campaign.get('project', '<name>')}/chaos.py)"))
    if log_gap(h):
        out.append(log_gap(h))
    return out


def journal_gap(h: History) -> str:
    """Why the RCL journal is not in the history ("" when it was read)."""
    if h.journal is None:
        return "no journal record: the RCL journal was not read"
    return f"the RCL journal could not be read: {h.journal.error}" if h.journal.error else ""


def log_gap(h: History) -> str:
    """Why the run's log is not in the history ("" when it was read)."""
    if h.log is None:
        return "no log record: the run's log was not read"
    return f"the run's log could not be read: {h.log.error}" if h.log.error else ""
