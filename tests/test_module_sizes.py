"""Modules are cut by idea: one over 400 lines says, in its docstring, why it is one idea."""

from __future__ import annotations

import ast
from pathlib import Path

MRSS = Path(__file__).resolve().parents[1] / "mrss"
LIMIT = 400
REASON = "One idea in one module"


def test_every_long_module_says_why_it_is_one_idea() -> None:
    long = {p: len(p.read_text(encoding="utf-8").splitlines()) for p in MRSS.rglob("*.py")}
    unexplained = [f"{p.relative_to(MRSS.parent)}: {n} lines"
                   for p, n in sorted(long.items()) if n > LIMIT
                   and REASON not in (ast.get_docstring(ast.parse(p.read_text())) or "")]
    assert not unexplained, "split by idea, or say why it is one:\n" + "\n".join(unexplained)
