"""What `mrss check` found: one `Finding` per problem, with where it is and what was expected.

Every finding names a file, and a line (and column) when there is one; `Report.text()`
prints them as `file:line:col: message` (the editor convention), `Report.as_json()` is
the same list for editors and CI. Errors make the project unrunnable (exit 2); warnings
are printed and do not change the exit code; `suppressed` says which files' dependants
were not checked because the file itself is broken (no cascades).
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable
from dataclasses import asdict, dataclass, field
from enum import StrEnum
from typing import Any


class Severity(StrEnum):
    """Whether a finding stops the project (error) or is only worth a look (warning)."""

    ERROR = "error"
    WARNING = "warning"


@dataclass(frozen=True)
class Finding:
    """One problem: where (file, line, col; 0 when unknown), what, and the check that saw it."""

    file: str
    message: str
    line: int = 0
    col: int = 0
    severity: Severity = Severity.ERROR
    check: str = ""
    key: str | None = None
    detail: str = ""  # e.g. a source line with a caret, printed under the message

    def location(self) -> str:
        return self.file + (f":{self.line}" if self.line else "") + \
            (f":{self.col}" if self.line and self.col else "")

    def text(self) -> str:
        key = f"key {self.key!r}: " if self.key else ""
        prefix = "" if self.severity is Severity.ERROR else "warning: "
        return f"{prefix}{self.location()}: {key}{self.message}" + \
            (f"\n{self.detail}" if self.detail else "")


@dataclass
class Report:
    """Every finding of one `mrss check` run, and a summary line per checked part."""

    project: str
    findings: list[Finding] = field(default_factory=list)
    summary: list[str] = field(default_factory=list)

    def add(self, finding: Finding) -> None:
        self.findings.append(finding)

    def error(self, file: str, message: str, *, line: int = 0, col: int = 0, check: str = "",
              key: str | None = None, detail: str = "") -> None:
        self.add(Finding(file, message, line, col, Severity.ERROR, check, key, detail))

    def warning(self, file: str, message: str, *, line: int = 0, col: int = 0,
                check: str = "", key: str | None = None) -> None:
        self.add(Finding(file, message, line, col, Severity.WARNING, check, key))

    @property
    def errors(self) -> list[Finding]:
        return [f for f in self.findings if f.severity is Severity.ERROR]

    @property
    def warnings(self) -> list[Finding]:
        return [f for f in self.findings if f.severity is Severity.WARNING]

    def as_json(self) -> dict[str, Any]:
        return {"project": self.project, "ok": not self.errors,
                "findings": [{**asdict(f), "severity": f.severity.value}
                             for f in self.findings]}


def did_you_mean(word: str, options: Iterable[str], *, what: str = "",
                 also: Iterable[str] = ()) -> str:
    """`; did you mean 'x'?` for a close option (or one of `also`), else `; known: a, b`
    listing `options` (or `` if there are none)."""
    known = sorted(set(options))
    close = difflib.get_close_matches(word, [*known, *also], n=1, cutoff=0.7)
    if close:
        return f"; did you mean {close[0]!r}?"
    if not known:
        return ""
    listing = ", ".join(known)
    return f"; {what or 'known'}: {listing}"
