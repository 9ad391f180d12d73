"""The examples of tasks addressed to a role in the docs run as written: the AgentSpeak
blocks of docs/agentspeak.md ("Tasks addressed to a role") and docs/rcl.md
("Allocation") are read from the files, loaded on the real interpreter with a scripted
RCL, and their actions become role-addressed requests (no robot, the role on the wire);
the reassigned/3 plan takes its percept without failing the task."""

from __future__ import annotations

import re
from pathlib import Path

from mrss.actors.reasoner.messages import action_request
from mrss.agentspeak import Struct, parse_literal
from mrss.api.testing import ScriptedHost

DOCS = Path(__file__).resolve().parents[2] / "docs"


def _blocks(doc: str, heading: str) -> list[str]:
    """The ```agentspeak blocks of the section `heading` (up to the next heading)."""
    text = (DOCS / doc).read_text()
    start = text.index(f"\n## {heading}\n")
    end = text.find("\n## ", start + 1)
    section = text[start:end if end >= 0 else len(text)]
    return re.findall(r"```agentspeak\n(.*?)```", section, re.S)


def _load(tmp_path: Path, source: str) -> ScriptedHost:
    path = tmp_path / "example.asl"
    path.write_text(source)
    host = ScriptedHost()
    host.load(path)
    return host


def _request(text: str) -> tuple[str, str, dict[str, object]]:
    literal = parse_literal(text)
    assert isinstance(literal, Struct)
    request = action_request(literal)
    return request.name, request.robot, request.role


def test_agentspeak_md_role_examples_send_role_addressed_requests(tmp_path: Path) -> None:
    actions, reassigned = _blocks("agentspeak.md", "Tasks addressed to a role")
    rcl = _load(tmp_path, actions + reassigned + "+go[source(percept)]\n"
                "   <- !!cover(c1, area1, 48.21, 16.37); !!look(l1).\n")
    rcl.feed("go")
    rcl.run_until(lambda: len(rcl.open) == 2)
    sent = sorted(rcl.open.values())
    assert sent == ["cover(any([uav,camera],at(48.21,16.37)),c1,area1)",
                    "inspect(any([camera]),l1)"]
    assert [_request(s) for s in sent] == [
        ("cover", "", {"capabilities": ["uav", "camera"], "near": [48.21, 16.37]}),
        ("inspect", "", {"capabilities": ["camera"]})]

    agent = rcl.agent
    assert agent is not None
    rcl.feed("reassigned(cover(any([uav,camera],at(48.21,16.37)),c1,area1), uav1, uav2)")
    agent.run_until_idle()
    assert not agent.believes("reassigned(_, _, _)")  # handled and removed
    assert len(rcl.open) == 2  # the task goes on: its action did not fail


def test_rcl_md_allocation_example_sends_a_role_addressed_request(tmp_path: Path) -> None:
    (example,) = _blocks("rcl.md", "Allocation: tasks addressed to a role")
    rcl = _load(tmp_path, example)
    rcl.feed("fire(f1, 48.21, 16.37)")
    rcl.run_until(lambda: len(rcl.open) == 1)
    (sent,) = rcl.open.values()
    assert _request(sent) == ("survey", "", {"capabilities": ["uav", "camera"],
                                             "near": [48.21, 16.37]})
