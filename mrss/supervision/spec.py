"""Child and supervisor specifications: what to start, how to restart, when to give up.

Modelled on Erlang/OTP's child spec and supervisor flags. A `ChildSpec` is generic in
how its child is started (a component class path for OS processes, a factory for actors);
everything else about restarting is the same for both levels.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Generic, Literal, TypeVar

from mrss.errors import SupervisionError

StartT = TypeVar("StartT")

KILL: Literal["kill"] = "kill"


class Restart(StrEnum):
    """When a child that exited is started again (OTP restart types)."""

    PERMANENT = "permanent"  # always
    TRANSIENT = "transient"  # only after an abnormal exit
    TEMPORARY = "temporary"  # never


class Strategy(StrEnum):
    """Which children restart together when one fails (OTP strategies)."""

    ONE_FOR_ONE = "one_for_one"  # only the failed child
    ONE_FOR_ALL = "one_for_all"  # every child
    REST_FOR_ONE = "rest_for_one"  # the failed child and those started after it


class ChildKind(StrEnum):
    """A leaf doing work, or a supervisor of further children."""

    WORKER = "worker"
    SUPERVISOR = "supervisor"


class OnExceeded(StrEnum):
    """What a supervisor does when restarts exceed its intensity."""

    ESCALATE = "escalate"  # OTP: stop every child, fail to the parent
    QUARANTINE = "quarantine"  # take only the offending child out, retry after probation


@dataclass(frozen=True)
class Backoff:
    """Delay between restarts of a crash-looping child: exponential, capped, jittered.

    The first restart after a healthy run is immediate; the n-th consecutive one waits
    `initial * factor**(n-2)`, at most `cap`, spread by +-`jitter` (a fraction) so that
    children failing together do not restart in lock-step.
    """

    initial: float = 0.1
    factor: float = 2.0
    cap: float = 5.0
    jitter: float = 0.2

    def __post_init__(self) -> None:
        _nonneg(self.initial, "backoff.initial")
        _nonneg(self.cap, "backoff.cap")
        if not math.isfinite(self.factor) or self.factor < 1.0:
            raise SupervisionError(f"backoff.factor must be >= 1, not {self.factor!r}")
        if not 0.0 <= self.jitter <= 1.0:
            raise SupervisionError(f"backoff.jitter must be within [0, 1], not {self.jitter!r}")

    def delay(self, streak: int, rand: float) -> float:
        """Seconds to wait before restart number `streak` of a run; `rand` is in [0, 1)."""
        if streak <= 1 or self.initial == 0.0:
            return 0.0
        base = min(self.cap, self.initial * self.factor ** min(streak - 2, 64))
        spread = base * self.jitter * (2.0 * rand - 1.0)
        return max(0.0, min(self.cap, base + spread))


@dataclass(frozen=True)
class ChildSpec(Generic[StartT]):
    """One supervised child: its id, how to start it, and its restart and shutdown rules.

    `shutdown` is the seconds a child gets to stop after being asked before it is
    killed, or "kill" to kill it at once (OTP's brutal_kill). `backoff = False` exempts
    the child from the supervisor's backoff (it still counts toward its intensity).
    """

    id: str
    start: StartT
    restart: Restart = Restart.PERMANENT
    shutdown: float | Literal["kill"] = 5.0
    kind: ChildKind = ChildKind.WORKER
    backoff: bool = True  # False: always restarted at once (the bus proxy: all need it)

    def __post_init__(self) -> None:
        if not self.id or not isinstance(self.id, str):
            raise SupervisionError(f"child id must be a non-empty string, not {self.id!r}")
        object.__setattr__(self, "restart", _enum(Restart, self.restart, self.id, "restart"))
        object.__setattr__(self, "kind", _enum(ChildKind, self.kind, self.id, "kind"))
        if not isinstance(self.backoff, bool):
            raise SupervisionError(f"child {self.id}: backoff must be true or false, "
                                   f"not {self.backoff!r}")
        if self.shutdown != KILL:
            if isinstance(self.shutdown, bool) or not isinstance(self.shutdown, int | float):
                raise SupervisionError(
                    f"child {self.id}: shutdown must be seconds or 'kill', not {self.shutdown!r}"
                )
            _nonneg(float(self.shutdown), f"child {self.id}: shutdown")

    @property
    def shutdown_timeout(self) -> float:
        """Seconds allowed for a graceful stop (0 for a brutal kill)."""
        return 0.0 if self.shutdown == KILL else float(self.shutdown)


@dataclass(frozen=True)
class Group:
    """A subtree of a supervisor's children: a budget of its own, escalation kept inside.

    A member that exceeds its own intensity restarts the whole group; more than
    `intensity` such group restarts within `period` seconds (None: the supervisor's
    period) and the group is given up as one (see `RestartPolicy`).
    """

    name: str
    children: tuple[str, ...]
    intensity: int = 1
    period: float | None = None

    def __post_init__(self) -> None:
        _count(self.intensity, f"group {self.name}: intensity")
        if self.period is not None:
            _positive(self.period, f"group {self.name}: period")
        if not self.name or not isinstance(self.name, str):
            raise SupervisionError(f"group name must be a non-empty string, not {self.name!r}")
        object.__setattr__(self, "children", tuple(self.children))
        if not self.children or not all(isinstance(c, str) and c for c in self.children):
            raise SupervisionError(f"group {self.name}: children must be a non-empty list of "
                                   f"child ids, not {list(self.children)!r}")
        if len(set(self.children)) != len(self.children):
            raise SupervisionError(f"group {self.name}: a child is listed twice")


@dataclass(frozen=True)
class SupervisorSpec:
    """A supervisor's flags: strategy, restart intensity, backoff, and healing rules.

    Every child has its own intensity window: more than `intensity` restarts of it within
    `period` seconds exceed it. `shared_intensity` (opt-in, OTP's classic flag) adds one
    window over all children's restarts. `groups` are subtrees that escalate inside
    themselves. What exceeding means is `on_exceeded`: escalate (stop everything, fail to
    the parent) or quarantine (stop only the culprit, child or group, and retry it after
    `probation` seconds; `math.inf`: never). A child that ran for `healthy_after` seconds
    has its failure streak (and so its backoff) forgotten. The rules: `RestartPolicy`.
    """

    strategy: Strategy = Strategy.ONE_FOR_ONE
    intensity: int = 3
    period: float = 5.0
    backoff: Backoff = field(default_factory=Backoff)
    healthy_after: float = 10.0
    on_exceeded: OnExceeded = OnExceeded.ESCALATE
    probation: float = 30.0
    shared_intensity: int | None = None
    groups: tuple[Group, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "strategy", _enum(Strategy, self.strategy, "", "strategy"))
        object.__setattr__(
            self, "on_exceeded", _enum(OnExceeded, self.on_exceeded, "", "on_exceeded")
        )
        _count(self.intensity, "intensity")
        if self.shared_intensity is not None:
            _count(self.shared_intensity, "shared_intensity")
        _positive(self.period, "period")
        _nonneg(self.healthy_after, "healthy_after")
        if isinstance(self.probation, bool) or not isinstance(self.probation, int | float) \
                or math.isnan(self.probation) or self.probation < 0:
            raise SupervisionError(f"probation must be seconds >= 0 (inf: never retried), "
                                   f"not {self.probation!r}")
        object.__setattr__(self, "groups", tuple(self.groups))
        if self.groups and self.strategy is not Strategy.ONE_FOR_ONE:
            raise SupervisionError(f"groups need strategy 'one_for_one', not "
                                   f"{self.strategy.value!r}")
        seen: dict[str, str] = {}
        for group in self.groups:
            if not isinstance(group, Group):
                raise SupervisionError(f"groups must be Group values, not {group!r}")
            if group.name in {g.name for g in self.groups if g is not group}:
                raise SupervisionError(f"group {group.name} is defined twice")
            for child in group.children:
                if child in seen:
                    raise SupervisionError(f"child {child} is in groups {seen[child]} and "
                                           f"{group.name}; a child belongs to one group")
                seen[child] = group.name


_E = TypeVar("_E", bound=StrEnum)


def _enum(cls: type[_E], value: object, child: str, name: str) -> _E:
    try:
        return cls(value)  # type: ignore[arg-type]  # any value; bad ones raise ValueError
    except ValueError:
        options = ", ".join(m.value for m in cls)
        who = f"child {child}: " if child else ""
        raise SupervisionError(f"{who}{name} must be one of {options}, not {value!r}") from None


def _count(value: int, name: str) -> None:
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise SupervisionError(f"{name} must be an integer >= 0, not {value!r}")


def _nonneg(value: float, name: str) -> None:
    if isinstance(value, bool) or not isinstance(value, int | float) \
            or not math.isfinite(value) or value < 0:
        raise SupervisionError(f"{name} must be a number >= 0, not {value!r}")


def _positive(value: float, name: str) -> None:
    _nonneg(value, name)
    if value == 0:
        raise SupervisionError(f"{name} must be > 0")
