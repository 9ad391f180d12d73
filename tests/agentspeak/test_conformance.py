"""Conformance suite: each conformance/NAME.asl must print exactly conformance/NAME.out
(`.print` lines and console-host actions), run in-process and through `mrss agent`."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from mrss.agentspeak.agent import Agent
from mrss.agentspeak.host import ConsoleHost, run_standalone
from mrss.agentspeak.stdlib import STDLIB

HERE = Path(__file__).parent / "conformance"
PROGRAMS = sorted(p.stem for p in HERE.glob("*.asl"))


def run_program(name: str) -> list[str]:
    lines: list[str] = []
    host = ConsoleHost(lines.append)
    path = HERE / f"{name}.asl"
    agent = Agent(file=path, host=host, name=name, out=lines.append)
    host.agent = agent
    assert run_standalone(agent, max_time=20), f"{name} did not become idle"
    return lines


@pytest.mark.parametrize("name", PROGRAMS)
def test_conformance_program_prints_expected_output(name: str) -> None:
    expected = (HERE / f"{name}.out").read_text(encoding="utf-8").splitlines()
    assert run_program(name) == expected


def test_conformance_suite_covers_every_internal_action_of_the_issue() -> None:
    required = [
        ".print", ".wait", ".drop_intention", ".intend", ".desire", ".drop_desire",
        ".succeed_goal", ".fail_goal", ".suspend", ".resume", ".drop_all_intentions",
        ".drop_all_desires", ".findall", ".count", ".member", ".length", ".nth", ".sort",
        ".reverse", ".delete", ".max", ".min", ".range", ".concat", ".substring", ".time",
        ".date", ".random", ".my_name", ".abolish", ".fail", "math.abs", "math.round",
        "math.floor", "math.ceil", "math.sqrt", "math.max", "math.min",
    ]
    text = "\n".join(p.read_text(encoding="utf-8") for p in HERE.glob("*.asl"))
    missing = [r for r in required if r + "(" not in text and r + ";" not in text
               and r + "." not in text and r + "\n" not in text]
    assert missing == [], missing


def test_every_internal_action_of_the_library_is_in_a_conformance_program() -> None:
    text = "\n".join(p.read_text(encoding="utf-8")
                     for p in [*HERE.glob("*.asl"), *HERE.glob("societies/**/*.asl")])
    missing = [name for name in STDLIB.names()
               if not re.search(re.escape(name) + r"(?![A-Za-z0-9_])", text)]
    assert missing == [], missing


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
