"""The seeded schedule of a campaign: which fault, on whom, when and for how long.

`plan` is pure: the same seed, count, kinds, targets, interval and durations give the
same faults, so a failing campaign is re-run exactly (`--seed`). Each fault picks a kind
uniformly among the requested kinds that have a target in the project, then a target of
that kind uniformly, waits a uniform time in `interval` after the previous fault, and a
timed fault lasts a uniform time in `duration`. The first fault comes one interval after
the faults begin. A robot is lost for good (`robot_loss`) at most once: a lost robot is
no target of a later one, and the kind is drawn no more once every robot is lost
(unless no other kind is left).
"""

from __future__ import annotations

import random
from collections.abc import Iterable, Mapping

from mrss.chaos.faults import ALL_KINDS, Fault, FaultKind
from mrss.errors import MrssError


class CampaignError(MrssError):
    """A campaign that cannot be planned (bad range, no kind with a target)."""


Range = tuple[float, float]


def parse_range(text: str, what: str) -> Range:
    """`A..B` (or one number) as a (low, high) pair of non-negative seconds."""
    low_text, sep, high_text = text.partition("..")
    try:
        low = float(low_text)
        high = float(high_text) if sep else low
    except ValueError:
        raise CampaignError(f"{what}: expected A..B seconds (e.g. 3..6), not {text!r}") \
            from None
    if low < 0 or high < low:
        raise CampaignError(f"{what}: expected 0 <= A <= B, not {text!r}")
    return low, high


def parse_kinds(text: str) -> list[FaultKind]:
    """A comma-separated list of fault kinds ("all": every kind but those never healed)."""
    if text.strip() == "all":
        return list(ALL_KINDS)
    kinds = []
    for name in (n.strip() for n in text.split(",") if n.strip()):
        try:
            kinds.append(FaultKind(name))
        except ValueError:
            raise CampaignError(f"--kinds: unknown fault kind {name!r}; known: "
                                f"{', '.join(k.value for k in FaultKind)}") from None
    if not kinds:
        raise CampaignError("--kinds: give at least one fault kind")
    return kinds


def plan(seed: int, count: int, kinds: Iterable[FaultKind],
         targets: Mapping[FaultKind, list[str]], interval: Range, duration: Range
         ) -> list[Fault]:
    """The campaign's faults in time order."""
    usable = [k for k in kinds if targets.get(k)]
    if count > 0 and not usable:
        raise CampaignError("none of the fault kinds asked for has a target in this project")
    rng = random.Random(seed)
    faults: list[Fault] = []
    left = {k: list(targets[k]) for k in usable}
    at = 0.0
    for _ in range(count):
        at += rng.uniform(*interval)
        kind = rng.choice([k for k in usable if left[k]] or usable)
        target = rng.choice(left[kind] or targets[kind])
        if kind.permanent and target in left[kind]:
            left[kind].remove(target)
        lasts = round(rng.uniform(*duration), 2) if kind.timed else 0.0
        faults.append(Fault(round(at, 2), kind, target, lasts, kind.amount))
    return faults
