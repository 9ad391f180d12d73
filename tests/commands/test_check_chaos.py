"""`mrss check` on a project's chaos.py: an operator that sends goals must declare the
beliefs that hold one (PENDING_BELIEFS), named as agent.asl names them."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from mrss.check import check_project
from mrss.check.findings import Finding, Severity
from mrss.config.loader import load_project

PROJECTS = Path(__file__).resolve().parents[2] / "projects"
DECLARED = 'PENDING_BELIEFS = ["on_hold", "task", "retrying"]'


@pytest.fixture
def wildfire(tmp_path: Path) -> Path:
    shutil.copytree(PROJECTS / "wildfire", tmp_path / "wildfire",
                    ignore=shutil.ignore_patterns("__pycache__"))
    return tmp_path / "wildfire"


def chaos_findings(project: Path) -> list[Finding]:
    report = check_project(load_project(project.name, project.parent))
    assert report.errors == []
    return [f for f in report.findings if f.check == "chaos"]


def edit_chaos(project: Path, old: str, new: str) -> int:
    """Replace `old` in chaos.py; the line it is on."""
    path = project / "chaos.py"
    text = path.read_text()
    assert old in text
    path.write_text(text.replace(old, new))
    return text[:text.index(old)].count("\n") + 1


def test_the_shipped_wildfire_operator_declares_its_pending_beliefs() -> None:
    assert chaos_findings(PROJECTS / "wildfire") == []


def test_an_operator_sending_goals_without_pending_beliefs_is_told_to_declare_them(
        wildfire: Path) -> None:
    line = edit_chaos(wildfire, DECLARED, "PENDING_BELIEFS: list[str] = []")
    [found] = chaos_findings(wildfire)
    assert found.severity is Severity.WARNING and found.key == "PENDING_BELIEFS"
    assert (found.file, found.line) == (str(wildfire / "chaos.py"), line)
    assert "the operator sends goals (a1, ...)" in found.message
    # the example is the project's own [operator.goals] queued / running
    assert "PENDING_BELIEFS = ['on_hold', 'task']" in found.message


def test_a_pending_belief_agent_asl_never_names_is_reported(wildfire: Path) -> None:
    edit_chaos(wildfire, DECLARED, 'PENDING_BELIEFS = ["task", "taks"]')
    [found] = chaos_findings(wildfire)
    assert "agent.asl never names taks(...)" in found.message


def test_an_operator_that_sends_no_goal_needs_no_pending_beliefs(wildfire: Path) -> None:
    edit_chaos(wildfire, DECLARED, "PENDING_BELIEFS: list[str] = []")
    edit_chaos(wildfire, 'yield {"after": pause, "intent": "goal"',
               'yield {"after": pause, "intent": "priority"')
    assert chaos_findings(wildfire) == []


def test_a_chaos_py_mrss_chaos_cannot_use_is_a_warning_naming_the_key(wildfire: Path) -> None:
    edit_chaos(wildfire, DECLARED, 'PENDING_BELIEFS = "queued"')
    [found] = chaos_findings(wildfire)
    assert found.key == "PENDING_BELIEFS" and "must be a list of strings" in found.message
