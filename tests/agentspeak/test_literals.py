"""The predicate builder writes literals that read back to exactly the intended values."""

from __future__ import annotations

import math
from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st

from mrss.actors.reasoner.percept_guard import checked_literal
from mrss.agentspeak.arith import ARITY
from mrss.agentspeak.literals import (
    Atom,
    PredicateError,
    Struct,
    check_literal,
    is_atom_name,
    literal,
    symbol,
    term,
)
from tests.edge.termcheck import read_literal

atom_names = st.from_regex(r"[a-z][a-zA-Z0-9_]{0,12}", fullmatch=True).filter(is_atom_name)
scalars = st.one_of(
    atom_names.map(Atom),
    st.text(max_size=30),
    st.integers(min_value=-(10**30), max_value=10**30),
    st.floats(allow_nan=False, allow_infinity=False),
    st.booleans(),
)
values = st.recursive(
    scalars,
    lambda inner: st.one_of(
        st.lists(inner, max_size=4),
        st.builds(lambda f, args: Struct(f, *args), atom_names, st.lists(inner, min_size=1,
                                                                         max_size=3)),
    ),
    max_leaves=12,
)


def expected(value: Any) -> Any:
    """What the independent reader must give back for a Python value."""
    if isinstance(value, Atom):
        return ("atom", str(value))
    if isinstance(value, bool):
        return ("atom", "true" if value else "false")
    if isinstance(value, (str, int, float)):
        return value
    if isinstance(value, Struct):
        return ("struct", value.functor, [expected(a) for a in value.args])
    return [expected(v) for v in value]


@given(atom_names, st.lists(values, max_size=6))
def test_built_literal_reads_back_to_the_same_arguments(functor: str, args: list[Any]) -> None:
    text = literal(functor, *args)
    name, got, annots = read_literal(text)
    assert name == functor
    assert got == [expected(a) for a in args]
    assert annots == []
    assert check_literal(text) == text


@given(st.lists(st.text(max_size=40), min_size=1, max_size=5))
def test_any_strings_stay_one_argument_each(texts: list[str]) -> None:
    name, got, _ = read_literal(literal("note", *texts))
    assert name == "note"
    assert got == texts


def test_injection_attempt_stays_one_string_argument() -> None:
    text = literal("area_goal_received", '"), evil(', 3)
    assert text == 'area_goal_received("\\"), evil(",3)'
    assert read_literal(text) == ("area_goal_received", ['"), evil(', 3], [])
    backslash = literal("p", 'a\\"), evil("')
    assert read_literal(backslash)[1] == ['a\\"), evil("']


def test_floats_are_written_without_exponent_and_round_trip() -> None:
    for value in (1e-5, 1e22, -0.0, 5e-324, 1.7976931348623157e308, 43.6):
        text = term(value)
        assert "e" not in text.lower()
        assert float(text) == value


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_numbers_are_refused(bad: float) -> None:
    with pytest.raises(PredicateError, match="not finite"):
        literal("p", bad)


@pytest.mark.parametrize("functor", ["Evil", "p(x)", "", "1p", "not", "p q", "p-q"])
def test_bad_functors_are_refused(functor: str) -> None:
    with pytest.raises(PredicateError):
        literal(functor, 1)


def test_atoms_are_validated_and_symbol_chooses_atom_or_string() -> None:
    with pytest.raises(PredicateError):
        Atom("H1")
    with pytest.raises(PredicateError):
        Atom("mod")  # reserved word
    assert isinstance(symbol("h1"), Atom)
    assert symbol("H1") == "H1" and not isinstance(symbol("H1"), Atom)
    assert literal("p", symbol("h1"), symbol("a b"), symbol("true")) == 'p(h1,"a b","true")'


@pytest.mark.parametrize("word", sorted({n for n in ARITY if "." not in n} | {
    "not", "div", "mod", "true", "false", "if", "else", "while", "for"}))
def test_a_word_the_reasoner_reads_as_no_atom_is_sent_as_a_string(word: str) -> None:
    """The edge's literals are the reasoner's percepts: a word its parser takes for an
    operator, a function call (`neg`) or a keyword goes out quoted, and is accepted."""
    assert not is_atom_name(word)
    text = literal("p", symbol(word), [symbol(word)])
    assert checked_literal(text).functor == "p"


def test_unsupported_values_are_refused_with_the_type() -> None:
    with pytest.raises(PredicateError, match="dict"):
        literal("p", {"a": 1})  # type: ignore[arg-type]
    with pytest.raises(PredicateError, match="NoneType"):
        literal("p", None)  # type: ignore[arg-type]
    with pytest.raises(PredicateError, match="Unicode"):
        literal("p", "\ud800")


def test_annotations_and_strong_negation() -> None:
    text = literal("~at", Atom("uav1"), annotations=[Struct("source", Atom("ui"))])
    assert text == "~at(uav1)[source(ui)]"
    assert read_literal(text) == ("~at", [("atom", "uav1")],
                                  [("struct", "source", [("atom", "ui")])])


@pytest.mark.parametrize("text", [
    "p(a,b", "p(a),q(b)", 'p("unterminated)', "P(a)", "p(a) extra", "p(,)", "",
    "p(not)", "p([a,])", "p(X)", "not(a)",
])
def test_check_literal_refuses_malformed_text(text: str) -> None:
    with pytest.raises(PredicateError):
        check_literal(text)


@pytest.mark.parametrize("text", [
    "p", "p(a)", ' p(a, "b c", -3.5, [1, [2]], q(r)) ', "p([])[source(x)]", "~p(1e3)",
])
def test_check_literal_accepts_well_formed_text(text: str) -> None:
    assert check_literal(text) == text.strip()
