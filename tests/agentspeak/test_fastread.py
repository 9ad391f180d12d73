"""The fast reader of ground literals gives exactly what the full parser gives."""

from __future__ import annotations

import pytest

from mrss.agentspeak import AslSyntaxError, Struct, Var, parse_literal, term_str
from mrss.agentspeak.fastread import read_simple
from mrss.agentspeak.parser import parse_term

SAME = [
    "fire", "area_goal_received(g1, 3)", "go(r3, 17)", " go(r3,17). ", "p(1.5, 2e3, 7E-2)",
    'msg("hello world", "")', "pos(uav1, [1, 2.5, [x, y]], done)", "f(g(h(a)), b)",
    "sensor.temp(s1, 21)", "teleop(ugv1, on)", "p(true, false)", "p(0, 00, 1.0)",
    "nested([a], [[b]])",
    # the full parser's cases: variables, annotations, negation, operators, escapes, ...
    "p(X, _)", "p(a)[source(camera)]", "~p(a)", "p(-3)", "p(1 + 2)", 'p("a\\"b")',
    "p([a | T])", "p([])", "p(math.abs(-2))", "p(not)", "f()", "p(a, b", "p(a) q",
]


def _same(a: object, b: object) -> bool:
    if isinstance(a, tuple) and isinstance(b, tuple):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, Struct) and isinstance(b, Struct):
        return (a.functor, a.neg, a.ground) == (b.functor, b.neg, b.ground) and \
            _same(a.args, b.args) and _same(a.annots, b.annots)
    if isinstance(a, Var) and isinstance(b, Var):  # anonymous ones get fresh names
        return a.name == b.name or (a.name.startswith("_") and b.name.startswith("_"))
    return type(a) is type(b) and term_str(a) == term_str(b)  # type: ignore[arg-type]


@pytest.mark.parametrize("text", SAME)
def test_parse_literal_with_the_fast_path_matches_the_full_parser(text: str) -> None:
    try:
        expected = parse_term(text)
    except AslSyntaxError as exc:
        with pytest.raises(AslSyntaxError) as got:
            parse_literal(text)
        assert str(got.value) == str(exc)  # the parser's own error message
        return
    assert _same(parse_literal(text), expected), text


def test_the_fast_path_takes_only_simple_ground_literals() -> None:
    assert read_simple("area_goal_received(g1, 3)") is not None
    for text in ("p(X)", "p(a)[source(x)]", "~p", "p(1 + 2)", 'p("a\\"b")', "p(a, b"):
        assert read_simple(text) is None, text
