"""Several agents in one process: each conformance/societies/NAME/ directory's agents
(in file-name order) must print exactly societies/NAME.out, in-process and through
`mrss agent a.asl b.asl ...`; bad uses fail the intention or exit 2, never a traceback."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from mrss.agentspeak.agent import read_program
from mrss.agentspeak.society import Society

HERE = Path(__file__).parent / "conformance" / "societies"
SOCIETIES = sorted(p.name for p in HERE.iterdir() if p.is_dir())


def _files(name: str) -> list[Path]:
    return sorted((HERE / name).glob("*.asl"))


@pytest.mark.parametrize("name", SOCIETIES)
def test_society_prints_expected_output_in_process(name: str) -> None:
    lines: list[str] = []
    society = Society(out=lines.append)
    for path in _files(name):
        society.add(path, read_program(path), path.stem)
    assert society.run(max_time=30), f"{name} did not become idle"
    assert lines == (HERE / f"{name}.out").read_text(encoding="utf-8").splitlines()


@pytest.mark.parametrize("name", SOCIETIES)
def test_society_prints_expected_output_through_mrss_agent(name: str) -> None:
    proc = subprocess.run([sys.executable, "-m", "mrss", "agent",
                           *map(str, _files(name)), "--max-time", "30"],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert "Traceback" not in proc.stderr
    assert proc.stdout.splitlines() == (HERE / f"{name}.out").read_text().splitlines()


def test_two_runs_print_the_same(tmp_path: Path) -> None:
    (tmp_path / "ping.asl").write_text(
        "!go.\n+!go <- for (.range(I, 1, 20)) { .send(pong, tell, n(I)) }.\n"
        "+m(I)[source(S)] <- .print(got(I, S)).\n")
    (tmp_path / "pong.asl").write_text(
        "+n(I)[source(S)] <- .print(n(I)); .send(S, tell, m(I)).\n")
    runs = []
    for _ in range(2):
        lines: list[str] = []
        society = Society(out=lines.append)
        for stem in ("ping", "pong"):
            path = tmp_path / f"{stem}.asl"
            society.add(path, read_program(path), stem)
        assert society.run(max_time=30)
        runs.append(lines)
    assert runs[0] == runs[1]
    assert sorted(runs[0]) == sorted([f"[pong] n({i})" for i in range(1, 21)]
                                     + [f"[ping] got({i},pong)" for i in range(1, 21)])


def test_bad_performative_fails_the_intention_and_names_the_choices(tmp_path: Path) -> None:
    (tmp_path / "a.asl").write_text("!go.\n+!go <- .send(b, shout, hi).\n")
    (tmp_path / "b.asl").write_text("")
    proc = subprocess.run([sys.executable, "-m", "mrss", "agent",
                           str(tmp_path / "a.asl"), str(tmp_path / "b.asl")],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0
    assert "Traceback" not in proc.stderr
    assert "a.asl:2: .send: unknown performative shout (expected one of tell, untell, " \
           "achieve, unachieve, askOne, askAll, tellHow)" in proc.stderr


def test_options_for_one_agent_are_refused_with_several(tmp_path: Path) -> None:
    for stem in ("a", "b"):
        (tmp_path / f"{stem}.asl").write_text("")
    proc = subprocess.run([sys.executable, "-m", "mrss", "agent", str(tmp_path / "a.asl"),
                           str(tmp_path / "b.asl"), "--percept", "p"],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2
    assert "mrss agent: --percept takes one agent file, not 2" in proc.stderr


def test_an_agent_waiting_on_a_timer_keeps_the_society_running(tmp_path: Path) -> None:
    (tmp_path / "a.asl").write_text("!g.\n+!g <- .wait(50); .send(b, tell, x).\n")
    (tmp_path / "b.asl").write_text("+x[source(S)] <- .print(got(S)).\n")
    lines: list[str] = []
    society = Society(out=lines.append)
    for stem in ("a", "b"):
        path = tmp_path / f"{stem}.asl"
        society.add(path, read_program(path), stem)
    assert society.run(max_time=30)
    assert lines == ["[b] got(a)"]


def test_agents_of_one_program_keep_their_own_plans_and_beliefs(tmp_path: Path) -> None:
    """Agents of one program text share its parsing and compiled code, never their
    state: one removing its plan and adding a belief leaves the other as loaded."""
    source = ("count(0).\n"
              "@greet +!greet <- ?count(N); .print(hello(N)).\n"
              "+!forget <- .remove_plan(greet); -+count(1).\n")
    lines: list[str] = []
    society = Society(out=lines.append)
    for stem in ("a", "b"):
        society.add(tmp_path / f"{stem}.asl", source, stem)
    a, b = society.agents.values()
    a.add_goal("forget")
    assert society.run(max_time=30)
    a.add_goal("greet")
    b.add_goal("greet")
    assert society.run(max_time=30)
    assert lines == ["[b] hello(0)"]
    assert a.believes("count(1)") and not b.believes("count(1)")
