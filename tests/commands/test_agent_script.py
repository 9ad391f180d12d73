"""`mrss agent`: percepts on the command line, percepts and outcomes scripted on stdin."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

AGENT = """\
+fire(A) <- !handle(A).
+!handle(A) <- query(area_size, [A], S); .print("size ", S); go(uav1, A); .print("done ", A).
-!handle(A)[error(E)] <- .print("failed ", A, " ", E).
"""


def mrss_agent(asl: Path, *args: str, stdin: str | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "mrss", "agent", str(asl), *args],
                          input=stdin, capture_output=True, text=True, timeout=60)


@pytest.fixture()
def asl(tmp_path: Path) -> Path:
    path = tmp_path / "fires.asl"
    path.write_text(AGENT, encoding="utf-8")
    return path


def test_percept_and_answer_options_drive_a_reactive_agent(asl: Path) -> None:
    proc = mrss_agent(asl, "--percept", "fire(a3)", "--answer", "area_size=7")
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.splitlines() == ["action: query(area_size,[a3],S)", "size 7",
                                        "action: go(uav1,a3)", "done a3"]


def test_an_unanswered_query_fails_with_its_reason(asl: Path) -> None:
    proc = mrss_agent(asl, "--percept", "fire(a3)")
    assert proc.returncode == 0
    assert proc.stdout.splitlines()[-1] == "failed a3 action_failed"


def test_stdin_script_ends_actions_and_answers_queries(asl: Path) -> None:
    script = "# two fires\n+fire(a1)\nok 1 42\n+fire(a2)\nok 3 [1, 2]\nfail 4 link_down\n" \
             "ok 2\n? fire(a1)\n? fire(a9)\n-fire(a1)\n? fire(a1)\n"
    proc = mrss_agent(asl, "--stdin", stdin=script)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.splitlines() == [
        "action 1: query(area_size,[a1],S)", "size 42", "action 2: go(uav1,a1)",
        "action 3: query(area_size,[a2],S)", "size [1,2]", "action 4: go(uav1,a2)",
        "failed a2 link_down", "done a1", "yes", "no", "no"]


def test_bad_script_lines_are_named_and_skipped(asl: Path) -> None:
    script = "+fire(a1)\nbogus\nok 9\nok x\nwait -1\n+fire(\nok 1 7\nok 2\n"
    proc = mrss_agent(asl, "--stdin", stdin=script)
    assert proc.returncode == 2
    assert proc.stdout.splitlines()[-1] == "done a1"     # the good lines all applied
    errors = proc.stderr.splitlines()
    assert errors[0].startswith("stdin:2: unknown command 'bogus' (expected +LIT")
    assert errors[1] == "stdin:3: no open action 9 (open: 1: query(area_size,[a1],S))"
    assert errors[2] == "stdin:4: ok needs an action number, not 'x' (expected ok N [TERM])"
    assert errors[3] == "stdin:5: '-1' is negative (expected wait S (seconds))"
    assert any(e.startswith("stdin:6: ") for e in errors)


def test_actions_left_open_at_the_end_of_the_script_exit_1(asl: Path) -> None:
    proc = mrss_agent(asl, "--stdin", stdin="+fire(a1)\nok 1 3\n")
    assert proc.returncode == 1
    assert "action 2 still open: go(uav1,a1)" in proc.stderr


def test_bad_command_line_values_exit_2(asl: Path) -> None:
    assert mrss_agent(asl, "--answer", "area_size").returncode == 2
    proc = mrss_agent(asl, "--percept", "fire(")
    assert proc.returncode == 2 and "mrss agent:" in proc.stderr
