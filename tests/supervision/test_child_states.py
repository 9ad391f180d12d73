"""A child's state moves by one table with causes, for both supervisors."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import mrss.supervision.actors
import mrss.supervision.process
from mrss.errors import SupervisionError
from mrss.supervision import child_states as cs
from mrss.supervision.status import ChildState


def cells(rows: list[str]) -> list[list[str]]:
    return [[c.strip() for c in r.strip().strip("|").split("|")] for r in rows]


def test_the_docstring_table_is_the_transition_table() -> None:
    doc = [line for line in (cs.__doc__ or "").splitlines() if line.startswith("|")]
    assert cells(doc) == cells(cs.table_rows())


def test_a_pair_the_table_lacks_is_refused_with_the_child_named() -> None:
    with pytest.raises(SupervisionError, match=r"child rcl: ready while running"):
        cs.move(ChildState.RUNNING, cs.ChildCause.READY, "rcl")
    assert cs.move(ChildState.STARTING, cs.ChildCause.READY) is ChildState.RUNNING


@pytest.mark.parametrize("module", [mrss.supervision.process, mrss.supervision.actors])
def test_no_supervisor_sets_a_child_state_but_through_the_table(module: object) -> None:
    """Every assignment to a child's `state` is `move(...)`: no state is set by hand."""
    tree = ast.parse(Path(str(getattr(module, "__file__", ""))).read_text())
    by_hand = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Assign):
            targets = [t for tgt in node.targets
                       for t in (tgt.elts if isinstance(tgt, ast.Tuple) else [tgt])]
            values = node.value.elts if isinstance(node.value, ast.Tuple) else [node.value]
            for target, value in zip(targets, values, strict=False):
                if isinstance(target, ast.Attribute) and target.attr == "state" and not (
                        isinstance(value, ast.Call) and getattr(value.func, "id", "") == "move"):
                    by_hand.append(node.lineno)
    assert by_hand == []


def test_every_cause_moves_some_state_and_every_state_is_reached() -> None:
    assert {c for _, c in cs.TRANSITIONS} == set(cs.ChildCause)
    assert set(cs.TRANSITIONS.values()) == set(ChildState)
