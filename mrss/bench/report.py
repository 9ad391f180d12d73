"""A benchmark's result: a titled table with targets, printed as text or JSON."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Any

Cell = str | int | float | None


@dataclass
class BenchReport:
    """Rows of measurements plus verdicts on the targets the issue sets."""

    name: str
    columns: list[str]
    rows: list[list[Cell]] = field(default_factory=list)
    targets: list[tuple[str, bool]] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    quick: bool = False

    def add_row(self, *cells: Cell) -> None:
        self.rows.append(list(cells))

    def check(self, description: str, met: bool) -> None:
        self.targets.append((description, met))

    def as_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "quick": self.quick,
            "columns": self.columns,
            "rows": self.rows,
            "targets": [{"target": t, "met": m} for t, m in self.targets],
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
            for target, met in self.targets:
                lines.append(f"- [{'x' if met else ' '}] {target}")
        lines.extend(f"- {n}" for n in self.notes)
        return "\n".join(lines)


def _row(cells: list[str], widths: list[int]) -> str:
    return "| " + " | ".join(c.ljust(w) for c, w in zip(cells, widths, strict=True)) + " |"


def _fmt(cell: Cell) -> str:
    if cell is None:
        return "-"
    if isinstance(cell, float):
        if cell >= 100:
            return f"{cell:,.0f}"
        if cell >= 1:
            return f"{cell:.2f}"
        return f"{cell:.3f}"
    if isinstance(cell, int):
        return f"{cell:,}"
    return cell
