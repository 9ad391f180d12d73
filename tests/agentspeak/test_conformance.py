"""Conformance suite: each conformance/NAME.asl must print exactly conformance/NAME.out
(`.print` lines and console-host actions), run in-process and through `mrss agent`.
The NAME.out files were written by hand from Jason's documented semantics; which of them
Jason itself prints is recorded in conformance/jason.toml."""

from __future__ import annotations

import enum
import hashlib
import subprocess
import sys
import tomllib
from collections import Counter
from pathlib import Path

import pytest

from mrss.agentspeak import arith, functions
from mrss.agentspeak.agent import Agent, read_program
from mrss.agentspeak.host import ConsoleHost, run_standalone
from mrss.agentspeak.registry import Registry
from mrss.agentspeak.society import Society
from mrss.agentspeak.stdlib import STDLIB
from tests.agentspeak.executed import counting, counting_functions

HERE = Path(__file__).parent / "conformance"
PROGRAMS = sorted(p.stem for p in HERE.glob("*.asl"))


def run_program(name: str, actions: Registry | None = None) -> list[str]:
    lines: list[str] = []
    host = ConsoleHost(lines.append)
    path = HERE / f"{name}.asl"
    agent = Agent(file=path, host=host, name=name, out=lines.append, actions=actions)
    host.agent = agent
    assert run_standalone(agent, max_time=20), f"{name} did not become idle"
    return lines


@pytest.mark.parametrize("name", PROGRAMS)
def test_conformance_program_prints_expected_output(name: str) -> None:
    expected = (HERE / f"{name}.out").read_text(encoding="utf-8").splitlines()
    assert run_program(name) == expected


# The internal actions and functions issue 4 asked for by name.
OF_THE_ISSUE = [
    ".print", ".wait", ".drop_intention", ".intend", ".desire", ".drop_desire",
    ".succeed_goal", ".fail_goal", ".suspend", ".resume", ".drop_all_intentions",
    ".drop_all_desires", ".findall", ".count", ".member", ".length", ".nth", ".sort",
    ".reverse", ".delete", ".max", ".min", ".range", ".concat", ".substring", ".time",
    ".date", ".random", ".my_name", ".abolish", ".fail", "math.abs", "math.round",
    "math.floor", "math.ceil", "math.sqrt", "math.max", "math.min",
]


def test_every_internal_action_and_function_runs_in_the_conformance_programs(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """Counted as they execute, in the programs and the societies: a name in a comment,
    a plan never run or a branch never taken does not count."""
    counts: Counter[str] = Counter()
    with counting_functions(monkeypatch, counts):
        for name in PROGRAMS:
            run_program(name, counting(STDLIB.child(), counts))
        for folder in sorted(p for p in (HERE / "societies").iterdir() if p.is_dir()):
            society = Society(out=lambda line: None)
            counting(society.registry, counts)
            for path in sorted(folder.glob("*.asl")):
                society.add(path, read_program(path), path.stem)
            assert society.run(max_time=30), f"{folder.name} did not become idle"
    library = [*STDLIB.names(), *arith.FUNCTIONS, *functions.TERM_ARITY]
    never = sorted({name for name in [*OF_THE_ISSUE, *library] if counts[name] == 0})
    assert never == [], f"never executed: {never}"


class Checked(enum.Enum):
    """What became of a conformance program on Jason (conformance/jason.toml)."""

    SAME = "same"  # Jason printed exactly NAME.out
    DIFFERS = "differs"  # Jason printed conformance/jason/NAME.out instead
    REFUSED = "refused"  # Jason did not run it (jason_error): NAME.out is ours alone


def test_jason_toml_says_for_every_program_what_jason_printed() -> None:
    """NAME.out files were written by hand; jason.toml (tests/agentspeak/jason_check.py)
    records which Jason reproduces. A NAME.out edited since is no longer checked."""
    manifest = tomllib.loads((HERE / "jason.toml").read_text(encoding="utf-8"))
    assert manifest["jason"]["source"]
    programs = manifest["programs"]
    assert sorted(programs) == PROGRAMS
    stale = []
    for name, entry in programs.items():
        verdict = Checked(entry["verdict"])
        ours = HERE / f"{name}.out"
        if hashlib.sha256(ours.read_bytes()).hexdigest() != entry["out_sha256"]:
            stale.append(name)
        theirs = HERE / "jason" / f"{name}.out"
        assert theirs.exists() == (verdict is Checked.DIFFERS), name
        if verdict is Checked.DIFFERS:
            assert theirs.read_text(encoding="utf-8") != ours.read_text(encoding="utf-8")
            assert entry.get("note"), f"{name}: say why ours differs from Jason"
        if verdict is Checked.REFUSED:
            assert entry.get("jason_error") and entry.get("note"), name
    assert stale == [], f"changed since checked against Jason (run jason_check): {stale}"


def test_mrss_agent_command_prints_and_exits_zero_when_idle() -> None:
    proc = subprocess.run([sys.executable, "-m", "mrss", "agent", str(HERE / "actions.asl")],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.splitlines() == (HERE / "actions.out").read_text().splitlines()


def test_mrss_agent_command_gives_up_after_max_time(tmp_path: Path) -> None:
    src = tmp_path / "loop.asl"
    src.write_text("!loop.\n+!loop <- .wait(50); !loop.\n")
    proc = subprocess.run([sys.executable, "-m", "mrss", "agent", str(src), "--max-time", "0.5"],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 1
    assert "still busy after 0.5 s" in proc.stderr
