"""A benchmark's result: a titled table with target rows, printed as text or JSON.

A target is data: the figure measured, the relation it must have to its bound, and the
reference the bound is derived from (e.g. "1.5x raw zmq ipc's p50"). Whether it is met
follows from those three; `exit_status` turns the targets into the command's exit code.
"""

from __future__ import annotations

import enum
import json
import math
from dataclasses import dataclass, field
from typing import Any

Cell = str | int | float | None


class Relation(enum.Enum):
    """How a target's figure must compare with its bound."""

    AT_MOST = "<="
    AT_LEAST = ">="
    BELOW = "<"

    def holds(self, figure: float, bound: float) -> bool:
        if self is Relation.AT_MOST:
            return figure <= bound
        if self is Relation.AT_LEAST:
            return figure >= bound
        return figure < bound


@dataclass(frozen=True)
class Target:
    """One target row: `figure RELATION bound`, the bound taken from `reference`.

    A figure that was not measured (None) or is not a finite number (NaN; infinite where
    a percentile fell on a late sample, or a rate over no time) meets nothing."""

    description: str
    figure: float | None
    relation: Relation
    bound: float
    reference: str = ""

    @property
    def met(self) -> bool:
        if self.figure is None or not math.isfinite(self.figure) or math.isnan(self.bound):
            return False
        return self.relation.holds(self.figure, self.bound)

    def as_dict(self) -> dict[str, Any]:
        return {"target": self.description, "met": self.met,
                "figure": _finite(self.figure), "relation": self.relation.value,
                "bound": _finite(self.bound), "reference": self.reference}

    def to_text(self) -> str:
        figure = "not measured" if self.figure is None else _fmt(self.figure)
        ref = f"; bound from {self.reference}" if self.reference else ""
        return (f"- [{'x' if self.met else ' '}] {self.description}: {figure} "
                f"{self.relation.value} {_fmt(self.bound)}{ref}")


def _finite(value: float | None) -> float | None:
    return value if value is not None and math.isfinite(value) else None


@dataclass
class BenchReport:
    """Rows of measurements plus the target rows the issues set."""

    name: str
    columns: list[str]
    rows: list[list[Cell]] = field(default_factory=list)
    targets: list[Target] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    quick: bool = False

    def add_row(self, *cells: Cell) -> None:
        self.rows.append(list(cells))

    def target(self, description: str, figure: float | None, relation: Relation,
               bound: float, reference: str = "") -> Target:
        """Add a target row (the figure measured against its bound); it is returned."""
        row = Target(description, figure, relation, bound, reference)
        self.targets.append(row)
        return row

    def check(self, description: str, met: bool) -> None:
        """A yes/no target (figure 1 if it held, 0 if not; bound 1)."""
        self.target(description, 1.0 if met else 0.0, Relation.AT_LEAST, 1.0, "yes = 1")

    def exit_status(self) -> int:
        """What `mrss bench` exits with: 1 when a target row is not met at full size.
        A --quick run is a smoke run at sizes too small for a verdict: 0."""
        if self.quick:
            return 0
        return 0 if all(t.met for t in self.targets) else 1

    def as_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "quick": self.quick,
            "columns": self.columns,
            "rows": self.rows,
            "targets": [t.as_dict() for t in self.targets],
            "notes": self.notes,
        }

    def to_json(self) -> str:
        return json.dumps(self.as_dict(), indent=2)

    def to_text(self) -> str:
        """A Markdown table, so it can be pasted into an issue note as it is."""
        header = [str(c) for c in self.columns]
        body = [[_fmt(c) for c in row] for row in self.rows]
        widths = [max(len(r[i]) for r in [header, *body]) for i in range(len(header))]
        lines = [f"## mrss bench {self.name}" + (" (quick)" if self.quick else ""), ""]
        lines.append(_row(header, widths))
        lines.append("|" + "|".join("-" * (w + 2) for w in widths) + "|")
        lines.extend(_row(row, widths) for row in body)
        if self.targets:
            lines.append("")
            lines.extend(t.to_text() for t in self.targets)
            missed = sum(not t.met for t in self.targets)
            lines.append(f"- targets: {len(self.targets) - missed} of {len(self.targets)} met"
                         + (" (--quick: not judged, exit 0)" if self.quick and missed else ""))
        lines.extend(f"- {n}" for n in self.notes)
        return "\n".join(lines)


def _row(cells: list[str], widths: list[int]) -> str:
    return "| " + " | ".join(c.ljust(w) for c, w in zip(cells, widths, strict=True)) + " |"


def _fmt(cell: Cell) -> str:
    if cell is None:
        return "-"
    if isinstance(cell, float):
        if math.isinf(cell):
            return "late" if cell > 0 else "-inf"
        if cell >= 100:
            return f"{cell:,.0f}"
        if cell >= 1:
            return f"{cell:.2f}"
        return f"{cell:.3f}"
    if isinstance(cell, int):
        return f"{cell:,}"
    return cell
