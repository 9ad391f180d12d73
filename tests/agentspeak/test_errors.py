"""Syntax error reports (file:line:col, the line and a caret, all errors of a file) and
runtime errors that fail one intention while the agent keeps running."""

from __future__ import annotations

import logging
import subprocess
import sys
from pathlib import Path

import pytest

from mrss.agentspeak.agent import Agent
from mrss.agentspeak.errors import AslSyntaxError
from mrss.errors import MrssError

BAD = """\
ok(1).
+!a <- .print("a") .print("b").
+!b : x & <- true.
good(2)
+!c <- true.
+!d <- .nosuch(1).
"""


def test_syntax_errors_are_all_reported_with_line_column_and_caret() -> None:
    with pytest.raises(AslSyntaxError) as info:
        Agent(BAD, file="bad.asl")
    err = info.value
    assert isinstance(err, MrssError)
    where = [(p.line, p.col) for p in err.problems]
    assert where == [(2, 21), (3, 11), (5, 1), (6, 8)]
    text = str(err)
    assert "bad.asl:2:21: unexpected 'print'" in text
    lines = text.splitlines()
    i = lines.index(next(ln for ln in lines if ln.startswith("bad.asl:3:11")))
    assert lines[i + 1] == "    +!b : x & <- true."
    assert lines[i + 2] == "    " + " " * 10 + "^"
    assert "bad.asl:6:8: unknown internal action .nosuch" in text


def test_unclosed_bracket_does_not_hide_later_errors() -> None:
    with pytest.raises(AslSyntaxError) as info:
        Agent("+!a <- x(.\n+!b <- y].\n", file="u.asl")
    assert [p.line for p in info.value.problems] == [1, 2]


def test_wrong_argument_count_of_internal_action_is_a_load_error() -> None:
    with pytest.raises(AslSyntaxError, match=r"p.asl:1:8: .length takes 2 arguments, not 1"):
        Agent("+!g <- .length(x).", file="p.asl")


def test_mrss_agent_exits_2_with_the_report_on_stderr(tmp_path: Path) -> None:
    src = tmp_path / "bad.asl"
    src.write_text(BAD)
    proc = subprocess.run([sys.executable, "-m", "mrss", "agent", str(src)],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2
    assert proc.stdout == ""
    assert f"{src}:3:11:" in proc.stderr and "^" in proc.stderr


def test_runtime_errors_fail_the_intention_naming_file_and_line(
        caplog: pytest.LogCaptureFixture) -> None:
    out: list[str] = []
    src = """\
!arith.
!unbound.
!fine.
+!arith <- X = "text" + 1; .print("never").
+!unbound <- move(Where); .print("never").
+!fine <- .print(one); .print(two).
"""
    agent = Agent(src, file="rt.asl", out=out.append, host=None)
    with caplog.at_level(logging.WARNING, logger="mrss.agentspeak"):
        agent.run_until_idle()
    assert out == ["one", "two"]
    messages = [r.getMessage() for r in caplog.records]
    assert any("rt.asl:4: arithmetic on a non-number" in m for m in messages), messages
    assert any("rt.asl:5: unbound variable Where in action move(Where)" in m for m in messages)
    assert agent.intentions == {}


def test_wrong_argument_count_of_a_math_function_is_a_load_error() -> None:
    with pytest.raises(AslSyntaxError) as info:
        Agent("+!g <- X = math.abs(1, 2) + 1.", file="f.asl")
    assert [str(p.message) for p in info.value.problems] == [
        "math.abs takes 1 argument, not 2"]


def _nested(depth: int) -> str:
    return "f(" * depth + "a" + ")" * depth


def test_a_term_300_deep_parses_unifies_and_prints() -> None:
    out: list[str] = []
    src = f"!g.\n+!g <- X = {_nested(300)}; +b(X); ?b(Y); .length([Y], N); .print(N).\n"
    agent = Agent(src, file="deep.asl", out=out.append)
    agent.run_until_idle()
    assert out == ["1"]


def test_a_term_nested_too_deeply_is_a_syntax_error_with_its_line() -> None:
    with pytest.raises(AslSyntaxError) as info:
        Agent(f"!g.\n+!g <- X = {_nested(1500)}.\n+!h <- true.\n", file="deep.asl")
    [problem] = info.value.problems
    assert (problem.line, problem.col) == (2, 1)
    assert "nested too deeply" in problem.message


def test_endless_rule_recursion_and_cyclic_terms_fail_their_intention_only(
        caplog: pytest.LogCaptureFixture) -> None:
    out: list[str] = []
    src = """\
len([_|T], N) :- len(T, M) & N = M + 1.
len([], 0).
!endless.
!cyclic.
!fine.
+!endless <- ?len([a|T], N); .print("never").
+!cyclic <- X = [1|X]; .print("never").
+!fine <- .print(one).
"""
    agent = Agent(src, file="rec.asl", out=out.append)
    with caplog.at_level(logging.WARNING, logger="mrss.agentspeak"):
        agent.run_until_idle()
    assert out == ["one"]
    messages = [r.getMessage() for r in caplog.records]
    assert any("rec.asl:6: ?len([a|T],N): recursion too deep" in m for m in messages), messages
    assert any("rec.asl:7: cyclic term: X would be bound to [1|X]" in m for m in messages)
    assert agent.intentions == {}


def test_mrss_agent_reports_endless_recursion_without_a_traceback(tmp_path: Path) -> None:
    src = tmp_path / "rec.asl"
    src.write_text("p(X) :- p(X).\n!g.\n+!g <- ?p(1).\n")
    proc = subprocess.run([sys.executable, "-m", "mrss", "agent", str(src)],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0
    assert "Traceback" not in proc.stderr
    assert f"{src}:3: ?p(1): recursion too deep" in proc.stderr


UNSUPPORTED = """\
{ begin namespace(x) }
!start.
+!start <- !a |&| !b.
^?g[state(S)] <- .print(S).
+!n <- X::b(1).
+!m <- .create_agent(bob, "bob.asl").
+!s <- .send(bob, tell, hi).
"""


def test_unsupported_jason_constructs_are_named_not_parse_errors() -> None:
    with pytest.raises(AslSyntaxError) as info:
        Agent(UNSUPPORTED, file="u.asl")
    found = [(p.line, p.col, p.message) for p in info.value.problems]
    assert found == [
        (1, 1, 'directives other than {include("file.asl")} ({begin ...}, ...) are not '
               'supported'),
        (3, 15, "fork and join (|&| and |||) are not supported"),
        (4, 1, "goal-state meta-events of test goals (^?g) are not supported; ^!g is"),
        (5, 9, "variable namespaces (X::b) are not supported: a namespace is an atom "
               "(ns::b)"),
        (6, 8, "`.create_agent` is not supported: agents are started and stopped by MRSS's "
               "supervisor and configuration, not by Jason's MAS infrastructure"),
        (7, 8, "`.send` is not supported: it needs other agents: run several (mrss agent "
               "a.asl b.asl, or the reasoner component's agents list)"),
    ]


NAMESPACE_MISUSES = """\
+!a <- +::b(1).
+!b <- +ns::ns2::c(1).
+!c <- +ns::X.
+!d <- +~ns::d.
+!e <- .print(ns::"s").
+!f <- ?ns::[1].
+!g <- +ns::~g(1); ?ns::~g(N); +default::h.
"""


def test_a_misused_namespace_is_named_at_its_place_not_a_parse_error() -> None:
    """MRSS's namespaces are prefixes of literals (ns::b); what Jason's parser refuses
    (ns::ns2::b, ~ns::b) or gives meaning only inside a module (::b) or at run time
    (ns::X, X::b) is a load error that says so, at file:line:col (issue 33's rule for
    bad input: every syntax error is `file:line:col: message`; AGENTSPEAK.md has no
    namespaces)."""
    with pytest.raises(AslSyntaxError) as info:
        Agent(NAMESPACE_MISUSES, file="ns.asl")
    found = [(p.line, p.col, p.message) for p in info.value.problems]
    assert found == [
        (1, 9, "`::b` names the local namespace of a module, and modules of namespaces "
               "({ begin namespace(ns) }) are not supported: write ns::b"),
        (2, 16, "a literal has one namespace (ns::b), not several"),
        (3, 13, "a namespace prefixes a literal (ns::b); a variable after it is not "
                "supported"),
        (4, 12, "the strong negation goes after the namespace: ns::~b, not ~ns::b"),
        (5, 19, "a namespace prefixes a literal (ns::b); a string after it is not "
                "supported"),
        (6, 13, "a namespace prefixes a literal (ns::b); a list after it is not supported"),
    ]
    assert str(info.value).startswith("ns.asl:1:9: ")


def test_an_initial_belief_with_an_annotation_tail_is_a_load_error() -> None:
    with pytest.raises(AslSyntaxError, match=r"b.asl:1:1: an initial belief or goal cannot "
                                             r"have an annotation tail \(b\[a\|T\]\)"):
        Agent("b[a|T].\n", file="b.asl")


def test_bad_add_plan_arguments_fail_their_intention_with_a_reason(
        caplog: pytest.LogCaptureFixture) -> None:
    out: list[str] = []
    src = """\
!a. !b. !c. !d.
@p1 +!x <- true.
+!a <- .add_plan({ @p1 +!y <- true }); .print("never").
+!b <- .add_plan("+!z <- ."); .print("never").
+!c <- .add_plan({ +!w <- true }, self, middle); .print("never").
+!d <- .add_plan({ @p1 +!x <- true }, bob); .remove_plan(p1); !x; .print(kept).
"""
    agent = Agent(src, file="ap.asl", out=out.append)
    with caplog.at_level(logging.WARNING, logger="mrss.agentspeak"):
        agent.run_until_idle()
    assert out == ["kept"]  # the same plan from bob: one more source, kept after self's goes
    messages = "\n".join(r.getMessage() for r in caplog.records)
    assert "ap.asl:3: .add_plan: there already is a plan with label p1" in messages
    assert "ap.asl:4: .add_plan: invalid plan '+!z <- .': unexpected '.'" in messages
    assert "ap.asl:5: .add_plan: the position must be begin or end, not middle" in messages


def test_include_errors_name_the_file_and_the_directive(tmp_path: Path) -> None:
    (tmp_path / "loop.asl").write_text('{ include("loop.asl") }\n')
    (tmp_path / "bad.asl").write_text("+!g <- .print(.\n")
    main = tmp_path / "main.asl"
    main.write_text('// three includes\n{ include("nope.asl") }\n{ include("loop.asl") }\n'
                    '{ include("bad.asl") }\n!g.\n')
    with pytest.raises(AslSyntaxError) as info:
        Agent(file=main)
    found = [(Path(p.file).name, p.line, p.col, p.message.split(" (")[0])
             for p in info.value.problems]
    assert ("main.asl", 2, 1, "cannot include 'nope.asl': No such file or directory") \
        in found, found
    assert ("loop.asl", 1, 1, "include 'loop.asl': more than 20 nested includes") in found
    assert any(f[0] == "bad.asl" and f[1] == 1 for f in found), found


def test_errors_in_an_included_file_name_that_file_and_line(tmp_path: Path) -> None:
    (tmp_path / "lib.asl").write_text("// a library\n+!h <- .nosuch(1).\n+!f <- X = 1 / 0.\n")
    main = tmp_path / "main.asl"
    main.write_text('{ include("lib.asl") }\n!g.\n+!g <- true.\n')
    with pytest.raises(AslSyntaxError) as info:
        Agent(file=main)
    [p] = info.value.problems
    assert (Path(p.file).name, p.line, p.col) == ("lib.asl", 2, 8)
    assert p.message == "unknown internal action .nosuch"
    (tmp_path / "lib.asl").write_text("// a library\n+!f <- X = 1 / 0.\n")
    main.write_text('{ include("lib.asl") }\n!f.\n')
    agent = Agent(file=main)
    assert next(iter(agent.plans.plans)).file == str(tmp_path / "lib.asl")


def test_a_broken_parser_cache_is_rebuilt_without_a_word(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capfd: pytest.CaptureFixture[str]
) -> None:
    from mrss.agentspeak import parser

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    try:
        parser._lark.cache_clear()
        parser._lark()  # builds the tables and writes the cache
        (cache,) = (tmp_path / "mrss").iterdir()
        assert (tmp_path / "mrss").stat().st_mode & 0o777 == 0o700
        cache.write_bytes(b"garbage\n\x80\x04not a pickle")
        parser._lark.cache_clear()
        assert parser.parse_literal("p(X, 1)[a]").functor == "p"  # rebuilt, and works
    finally:
        parser._lark.cache_clear()
    assert capfd.readouterr() == ("", "")


def test_a_belief_update_through_a_variable_that_is_no_literal_fails_with_the_reason(
        caplog: pytest.LogCaptureFixture) -> None:
    out: list[str] = []
    agent = Agent("!a. !b. !c.\n+!a <- +S; .print(never).\n+!b <- X = 3; -X.\n"
                  "+!c <- Y = \"s\"; -+Y.\n", file="bv.asl", out=out.append)
    with caplog.at_level(logging.WARNING, logger="mrss.agentspeak"):
        agent.run_until_idle()
    assert out == []
    messages = "\n".join(r.getMessage() for r in caplog.records)
    assert "bv.asl:2: unbound variable S used as a belief in +S" in messages
    assert "bv.asl:3: -X: 3 is not a literal" in messages
    assert 'bv.asl:4: -+Y: "s" is not a literal' in messages


def test_a_named_variable_as_a_plan_terms_label_is_a_load_error_that_says_so() -> None:
    """`{ @_ +!g }` is a plan term without a label of its own (Jason's grammar); a named
    variable would be a label computed at run time, which is refused where it is."""
    with pytest.raises(AslSyntaxError, match=r"p.asl:1:20: a plan term's label may be a "
                                             r"variable only as `@_`"):
        Agent("+!g <- .add_plan({ @L +!p <- x }).", file="p.asl")
    out: list[str] = []
    assert Agent("!g.\n+!g <- .add_plan({ @_ +!p <- .print(x) }); !p.\n",
                 out=out.append).run_until_idle() is not False
    assert out == ["x"]
