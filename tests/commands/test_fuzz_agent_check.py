"""Every command is total (issue 15 item 5): `mrss agent` and `mrss check` on seeded
random and near-valid files and extreme arguments end with exit 0, 1 or 2 and a clear
message, never a traceback, and within their own time limits."""

from __future__ import annotations

import os
import random
import subprocess
import sys
from pathlib import Path

import pytest

from tests.commands.cli_bus import ROOT, mrss
from tests.commands.fuzz_inputs import (
    EXTREME_NUMBERS,
    VALID_ASL,
    argument,
    assert_total,
    hostile_file,
    mutate_text,
    run_main,
    write,
)

SEED = 1515
ROUNDS = 60
MAX_TIME = "0.2"  # every run below is bounded by the command's own --max-time


@pytest.mark.timeout(300)
def test_agent_on_hostile_files_is_total(tmp_path: Path) -> None:
    rng = random.Random(SEED)
    codes = set()
    for i in range(ROUNDS):
        path = write(tmp_path / f"a{i}.asl", hostile_file(rng, VALID_ASL))
        argv = ["agent", str(path), "--max-time", MAX_TIME]
        outcome = run_main(argv)
        assert_total(outcome, argv)
        codes.add(outcome.code)
    assert 2 in codes  # most of them are rejected, with a message


@pytest.mark.timeout(300)
def test_agent_with_extreme_arguments_is_total(tmp_path: Path) -> None:
    rng = random.Random(SEED + 1)
    program = write(tmp_path / "ok.asl", VALID_ASL.encode())
    for _ in range(ROUNDS):
        argv = ["agent", str(program), "--max-time", rng.choice([MAX_TIME, *EXTREME_NUMBERS])]
        for _ in range(rng.randrange(3)):
            argv += [rng.choice(["--percept", "--answer", "--name"]), argument(rng)]
        if rng.randrange(3) == 0:
            argv.append("--stdin")
        script = "\n".join(mutate_text(rng, "+area(a1)\nok 1 3\nwait 0.01\n? count(1)\n")
                           for _ in range(rng.randrange(3)))
        outcome = run_main(argv, stdin=script)
        assert_total(outcome, argv)


@pytest.mark.timeout(120)
@pytest.mark.parametrize("stdin", [False, True])
def test_max_time_stops_a_busy_agent(tmp_path: Path, stdin: bool) -> None:
    path = write(tmp_path / "busy.asl", b"!g.\n+!g <- !g.\n")
    argv = ["agent", str(path), "--max-time", "0.3", *(["--stdin"] if stdin else [])]
    outcome = run_main(argv, stdin="+x\n")
    assert outcome.code == 1
    assert "still busy after 0.3 s" in outcome.err


def test_numbers_too_large_for_a_float_are_syntax_errors(tmp_path: Path) -> None:
    path = write(tmp_path / "big.asl", f"a(1e400).\nb({'9' * 400}).\nc(1.5e308).\n".encode())
    outcome = run_main(["agent", str(path)])
    assert outcome.code == 2
    assert f"{path}:1:3: number 1e400 is too large" in outcome.err
    assert f"{path}:2:3: number 9999999999...999999 (400 characters) is too large" \
        in outcome.err
    assert f"{path}:3:" not in outcome.err  # 1.5e308 fits a float


def test_a_non_utf8_file_names_file_line_and_byte_offset(tmp_path: Path) -> None:
    path = write(tmp_path / "latin1.asl", "ok.\n+!g <- .print(\"café\").\n".encode("latin-1"))
    outcome = run_main(["agent", str(path)])
    assert outcome.code == 2
    assert f"{path}:2:19: not UTF-8 text: byte 0xe9 at byte offset 22" in outcome.err


def test_a_busy_agent_as_a_process_stops_at_max_time(tmp_path: Path) -> None:
    path = write(tmp_path / "busy.asl", b"!g.\n+!g <- !g.\n")
    done = mrss("agent", str(path), "--max-time", "0.5")
    assert done.returncode == 1, done.stderr
    assert done.stderr.strip() == "mrss agent: still busy after 0.5 s"


def test_extreme_max_times_are_refused_by_a_process(tmp_path: Path) -> None:
    """As a process (no test timeout's alarm in the way): no overflow of the OS timers."""
    path = write(tmp_path / "ok.asl", b"ok.\n")
    for value in ("1e10", "1e308", "-1", "nan", "inf"):
        done = mrss("agent", str(path), "--max-time", value)
        assert done.returncode == 2, done.stderr
        assert "expected seconds from 0 to 1e+06" in done.stderr, done.stderr
    done = mrss("agent", str(path), "--max-time", "1e6")
    assert done.returncode == 0, done.stderr


@pytest.mark.timeout(300)
def test_agent_processes_on_hostile_files_print_no_traceback(tmp_path: Path) -> None:
    rng = random.Random(SEED + 2)
    for i in range(6):
        path = write(tmp_path / f"p{i}.asl", hostile_file(rng, VALID_ASL))
        done = mrss("agent", str(path), "--max-time", MAX_TIME)
        assert "Traceback" not in done.stderr, done.stderr
        assert done.returncode in (0, 1, 2), done.stderr


PROJECT_TOML = """\
[project]
name = "fz"

[components.reasoner]
kind = "reasoner"
agent = "agent.asl"
beliefs = ["level(a1, 2)"]
"""


@pytest.mark.timeout(300)
def test_check_on_hostile_projects_is_total(tmp_path: Path,
                                            monkeypatch: pytest.MonkeyPatch) -> None:
    rng = random.Random(SEED + 3)
    monkeypatch.setenv("MRSS_PROJECTS", str(tmp_path))
    for i in range(ROUNDS // 2):
        project = tmp_path / f"fz{i}"
        project.mkdir()
        toml = PROJECT_TOML.replace('"fz"', f'"fz{i}"')
        toml_bytes = hostile_file(rng, toml) if rng.randrange(2) else toml.encode()
        write(project / "project.toml", toml_bytes)
        write(project / "agent.asl", hostile_file(rng, VALID_ASL))
        for argv in (["check", f"fz{i}"], ["check", f"fz{i}", "--json"],
                     ["check", argument(rng) or "x"]):
            assert_total(run_main(argv), argv)


def test_check_reports_load_time_errors_and_bad_beliefs(tmp_path: Path,
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MRSS_PROJECTS", str(tmp_path))
    project = tmp_path / "fz"
    project.mkdir()
    write(project / "project.toml", PROJECT_TOML.replace("level(a1, 2)", "b(X+1)").encode())
    write(project / "agent.asl", b"ok.\n")
    outcome = run_main(["check", "fz"])
    assert outcome.code == 2
    assert "beliefs:1:1: initial belief 'b(X+1)': unbound variable X" in outcome.err


@pytest.mark.parametrize(("body", "message"), [
    ("X = 2 ** 99999999; .print(X)", "2 ** 99999999 is too large"),
    ("X = 10 ** 300 * 10 ** 300 * 1.5; .print(X)", "int too large to convert to float"),
    ("X = 10 ** 300; Y = X * X * X * X * X * X * X * X * X * X * X * X * X * X * X; "
     ".print(Y)", "Exceeds the limit (4300 digits)"),
    ("X = 7 div 0", "division by zero"),
])
def test_arithmetic_beyond_a_float_fails_the_intention_not_the_agent(
        tmp_path: Path, body: str, message: str) -> None:
    path = write(tmp_path / "big.asl", f"!g.\n+!g <- {body}.\n-!g <- .print(recovered).\n"
                 .encode())
    outcome = run_main(["agent", str(path), "--max-time", "5"])
    assert outcome.code == 0, outcome.err
    assert outcome.out.strip() == "recovered"


def test_a_percept_with_arithmetic_on_an_unbound_variable_is_a_bad_argument(
        tmp_path: Path) -> None:
    path = write(tmp_path / "ok.asl", b"ok.\n")
    outcome = run_main(["agent", str(path), "--percept", "b(X+1)"])
    assert outcome.code == 2
    assert "unbound variable X in arithmetic expression" in outcome.err


@pytest.mark.timeout(120)
@pytest.mark.parametrize("stdin", [False, True])
def test_max_time_stops_one_reasoning_step_that_never_ends(tmp_path: Path, stdin: bool) -> None:
    """A single step (a .findall over 10^8 numbers) is stopped too, not only a busy loop."""
    path = write(tmp_path / "long.asl",
                 b"!g.\n+!g <- .findall(X, .range(X, 1, 100000000), L); .print(done).\n")
    argv = ["agent", str(path), "--max-time", "0.3", *(["--stdin"] if stdin else [])]
    outcome = run_main(argv)
    assert outcome.code == 1
    assert "still busy after 0.3 s" in outcome.err
    assert "done" not in outcome.out


@pytest.mark.parametrize("special", ["/dev/zero", "/"])
def test_an_endless_file_or_a_directory_is_refused(special: str) -> None:
    outcome = run_main(["agent", special])
    assert outcome.code == 2
    assert outcome.err.startswith(f"mrss agent: cannot read {special}: ")


def test_a_script_line_that_is_not_utf8_is_named_and_skipped(tmp_path: Path) -> None:
    path = write(tmp_path / "ok.asl", b"ok.\n")
    env = {**os.environ, "LC_ALL": "C.UTF-8", "LANG": "C.UTF-8"}  # strict stdin decoding
    done = subprocess.run([sys.executable, "-m", "mrss", "agent", str(path), "--stdin"],
                          input=b"+a\n+b(\xff)\n? a\n", capture_output=True, env=env,
                          cwd=ROOT, timeout=60)
    assert done.returncode == 2
    assert done.stdout == b"yes\n"
    assert done.stderr == b"stdin:2: not UTF-8 text: byte 0xff at column 4\n"
