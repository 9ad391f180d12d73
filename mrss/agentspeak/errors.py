"""Errors of the AgentSpeak interpreter: syntax reports and runtime failures."""

from __future__ import annotations

from dataclasses import dataclass

from mrss.errors import MrssError


@dataclass(frozen=True)
class SyntaxProblem:
    """One syntax error: where it is, what is wrong, and the source line it is on."""

    file: str
    line: int
    col: int
    message: str
    source_line: str

    def report(self) -> str:
        """`file:line:col: message`, the source line, and a caret under the column."""
        caret = " " * (max(self.col, 1) - 1) + "^"
        return (f"{self.file}:{self.line}:{self.col}: {self.message}\n"
                f"    {self.source_line}\n    {caret}")


class AslSyntaxError(MrssError):
    """An AgentSpeak source has syntax errors; `problems` lists every one found."""

    def __init__(self, problems: list[SyntaxProblem]) -> None:
        self.problems = problems
        super().__init__("\n".join(p.report() for p in problems))

    @property
    def file(self) -> str:
        return self.problems[0].file if self.problems else "<string>"


class AslRuntimeError(MrssError):
    """A body formula could not be executed (bad arithmetic, unbound variable, bad argument).

    Raised inside the interpreter; the step that raised it fails its intention with
    `error` as the Jason error atom and the message naming the file and line.
    """

    def __init__(self, message: str, *, error: str = "ia_failed",
                 annots: tuple[object, ...] = ()) -> None:
        self.message = message
        self.error = error
        self.annots = annots  # extra annotations for the -!g event (from `.fail(...)`)
        super().__init__(message)
