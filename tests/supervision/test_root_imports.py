"""The root supervisor holds only what it uses: reading a project's operator topics
(the incident recorder's) leaves the AgentSpeak interpreter and its parser (lark) out of
its process, where they would be megabytes held for the whole run (`mrss bench memory`);
the components forked from the fork server share their copy instead."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

PROBE = """
import sys
from pathlib import Path
from mrss.config.loader import load_file
from mrss.commands import supervise_root
from mrss.config.operator import SECTION, operator_topics
config = load_file(Path(sys.argv[1]))
topics = operator_topics(config.sections.get(SECTION))
print(" ".join(topics))
from mrss.agentspeak import parse_literal
assert str(parse_literal("area_goal_received(g1, 3)")) == "area_goal_received(g1,3)"
heavy = sorted(m for m in sys.modules if m == "lark" or m.startswith("lark.")
               or m in ("mrss.agentspeak.agent", "mrss.agentspeak.runtime",
                        "mrss.agentspeak.builder"))
print(" ".join(heavy) or "-")
"""


def test_the_root_reads_operator_topics_without_the_interpreter_or_its_parser() -> None:
    toml = ROOT / "projects" / "wildfire" / "project.toml"
    out = subprocess.run([sys.executable, "-c", PROBE, str(toml)], capture_output=True,
                         text=True, timeout=120, cwd=ROOT)
    assert out.returncode == 0, out.stderr
    topics, heavy = out.stdout.splitlines()
    assert heavy == "-"
    # the same topics as the whole table's reading gives (wildfire declares a command)
    from mrss.config.loader import load_file
    from mrss.config.operator import SECTION, read_operator
    config = load_file(ROOT / "projects" / "wildfire" / "project.toml")
    full = read_operator(config.sections.get(SECTION), file=str(config.file))
    assert full.commands
    assert topics.split() == [*full.topics.values(), *(c.topic for c in full.commands.values())]


def test_a_goal_pattern_still_parses_and_a_full_program_loads_the_parser() -> None:
    probe = ("import sys\n"
             "from mrss.config.operator import parse_pattern\n"
             "p = parse_pattern('task(Robot, Goal, Priority)')\n"
             "assert (p.functor, p.positions) == ('task', {'Robot': 0, 'Goal': 1, "
             "'Priority': 2}), p\n"
             "from mrss.agentspeak.parser import parse_program\n"
             "prog = parse_program('+!g : true <- .print(hi).')\n"
             "print(len(prog.statements), 'lark' in sys.modules)\n")
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                         timeout=120, cwd=ROOT)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["1", "True"]
