"""Property tests of what the reasoner accepts as a percept (mrss.actors.reasoner.percept_guard)."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mrss.actors.reasoner.percept_guard import MAX_DEPTH, MAX_TEXT, checked_literal
from mrss.agentspeak import Struct
from mrss.agentspeak.literals import is_atom_name
from mrss.edge.validation import Rejected

# Words the grammar reads as operators, calls or keywords (`not`, `neg`, `div`) are no atoms.
atoms = st.from_regex(r"[a-z][a-z0-9_]{0,8}", fullmatch=True).filter(is_atom_name)
numbers = st.integers(-(2 ** 53), 2 ** 53) | st.floats(allow_nan=False, allow_infinity=False,
                                                        width=32)
strings = st.text(st.characters(codec="utf-8", exclude_categories=("Cc", "Cs"),
                                      exclude_characters='"\\'), max_size=10).map(
    lambda s: f'"{s}"')
terms = st.recursive(atoms | numbers.map(repr) | strings,
                     lambda inner: st.lists(inner, max_size=3).map(lambda a: f"[{','.join(a)}]")
                     | st.tuples(atoms, st.lists(inner, min_size=1, max_size=3)).map(
                         lambda fa: f"{fa[0]}({','.join(fa[1])})"), max_leaves=12)


@settings(max_examples=200, deadline=None)
@given(atoms, st.lists(terms, max_size=4))
def test_ground_bounded_literals_are_accepted(functor: str, args: list[str]) -> None:
    text = f"{functor}({','.join(args)})" if args else functor
    literal = checked_literal(text)
    assert isinstance(literal, Struct) and literal.functor == functor


@settings(max_examples=300, deadline=None)
@given(st.text(max_size=80))
def test_any_text_is_accepted_or_refused_never_an_other_error(text: str) -> None:
    try:
        checked_literal(text)
    except Rejected as exc:
        assert exc.reason.startswith("percept")


@settings(max_examples=100, deadline=None)
@given(atoms, st.sampled_from(["self", "percept", "operator", "uav1"]))
def test_a_sender_set_source_is_refused(functor: str, source: str) -> None:
    with pytest.raises(Rejected, match="percept sets its source"):
        checked_literal(f"{functor}(a)[source({source})]")
    assert checked_literal(f"{functor}(a)[seen_by(uav1)]").annots  # other annotations stay


@pytest.mark.parametrize("text", ["f(math.abs)", "f(a,neg)", "f(math.max(1))",
                                  "f(math.pi(1))", "f(math.sqrt(1,2))", "f(math.round)"])
def test_a_function_called_with_the_wrong_arguments_is_refused(text: str) -> None:
    with pytest.raises(Rejected, match=r"takes \d.* argument"):
        checked_literal(text)


@pytest.mark.parametrize(("text", "reason"), [
    ("go(X, g1)", "percept not ground"),
    ("go(r1, [a | T])", "percept not ground"),
    ("t(1e999)", "number 1e999 is too large"),  # the parser refuses it already
    ("t(-1e999)", "number 1e999 is too large"),
    ("t(" + "9" * 400 + ")", "400 characters. is too large"),  # ")" as "." here
    ("t(9**9**9)", "percept has exponentiation"),
    ("t(2^4000)", "percept has exponentiation"),
    ("t(" + "f(" * (MAX_DEPTH + 1) + "a" + ")" * (MAX_DEPTH + 1) + ")", "percept nested too"),
    ("t(" + "[" * 3000 + "]" * 3000 + ")", "percept nested too deeply"),
    ('t("' + "x" * MAX_TEXT + '")', "percept too large"),
    ("t(a", "percept not a literal"),
    ("+!g(a)", "percept not a literal"),
])
def test_malformed_percepts_are_refused_with_a_reason(text: str, reason: str) -> None:
    with pytest.raises(Rejected, match=reason.replace("(", r"\(").replace("^", r"\^")):
        checked_literal(text)


def test_brackets_inside_strings_do_not_count_as_nesting() -> None:
    text = 't("' + "(" * (MAX_DEPTH * 2) + '", inf)'
    assert checked_literal(text).args[0] == "(" * (MAX_DEPTH * 2)
