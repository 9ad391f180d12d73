"""`mrss check` on tasks addressed to a role: the robots' capabilities in project.toml,
and every `any([...])` of agent.asl one some robot could take (file, line, did you mean).
Each case copies projects/template, changes its robot's capabilities and writes a role
into its agent."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from tests.commands.test_check_mistakes import Mistake, inject, line_of, project, run_check

__all__ = ["project"]  # the fixture, shared

CAPS = Mistake("robot1 has capabilities", "project.toml", 'capabilities = ["ground"]',
               'capabilities = ["ground", "camera"]', "", "")


def _role(project: Path, role: str) -> None:
    inject(project, CAPS)
    inject(project, Mistake("a role", "agent.asl", "   <- move(R, G, Lat, Lon);",
                            f"   <- move({role}, G, Lat, Lon);", "", ""))


def _errors(capsys: pytest.CaptureFixture[str]) -> list[dict[str, object]]:
    code, report = run_check(capsys)
    errors = [f for f in report["findings"] if f["severity"] == "error"]
    assert (code == 2) == bool(errors), report
    return errors


def test_a_role_some_robot_can_take_passes(project: Path,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    _role(project, "any([camera], at(48.2, 16.3))")
    assert _errors(capsys) == []


@pytest.mark.parametrize(("role", "message"), [
    ("any([camra])", r"move/4 is addressed to any\(\[camra\]\), but no robot has the "
                     r"capability 'camra' \(did you mean 'camera'\?\): no robot could ever "
                     r"take it .*declares camera, ground"),
    ("any([camera, water])", r"no robot has the capability 'water'"),
])
def test_a_role_no_robot_could_take_is_an_error_at_its_line(
        project: Path, capsys: pytest.CaptureFixture[str], role: str, message: str) -> None:
    _role(project, role)
    errors = _errors(capsys)
    assert [(e["file"], e["line"]) for e in errors] == [
        (str(project / "agent.asl"), line_of(project / "agent.asl", f"move({role}"))]
    assert re.search(message, str(errors[0]["message"])), errors


def test_a_capability_that_is_no_name_is_an_error_in_project_toml(
        project: Path, capsys: pytest.CaptureFixture[str]) -> None:
    inject(project, Mistake("", "project.toml", 'capabilities = ["ground"]',
                            'capabilities = ["ground", "Camera"]', "", ""))
    errors = _errors(capsys)
    assert [(e["line"], e["key"]) for e in errors] == [
        (line_of(project / "project.toml", 'capabilities = ["ground", "Camera"]'),
         "components.rcl.robots.robot1.capabilities")]
    assert "capabilities are lowercase names" in str(errors[0]["message"])
