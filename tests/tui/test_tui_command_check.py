"""`mrss check` on `[operator.commands]`: each mistake named at its line with the key and
"did you mean", and a command whose percept no plan of the agent handles is an error."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from mrss.check import check_project
from mrss.config.loader import load_file
from tests.tui.conftest import HERE

GOOD = 'percept = "exclusion_zone(Zone, Shape)"'


@pytest.fixture()
def project(tmp_path: Path) -> Path:
    project = tmp_path / "tuimission"
    shutil.copytree(HERE / "tuimission", project)
    (project / "agent.asl").write_text((Path(__file__).parents[2] / "projects" / "wildfire"
                                        / "agent.asl").read_text())
    toml = project / "project.toml"
    toml.write_text(toml.read_text().replace("../../../projects/wildfire/agent.asl",
                                             "agent.asl"))
    return toml


def _line(text: str, needle: str) -> int:
    return next(i for i, line in enumerate(text.splitlines(), 1) if needle in line)


@pytest.mark.parametrize(("old", "new", "message", "at"), [
    (GOOD, 'percept = "exclusion_zone(Zone, Shap)"',
     "Shap is no field of the command (fields as variables: Zone, Shape); "
     "did you mean 'Shape'?", "percept ="),
    ('type = "polygon"', 'type = "polygon2"',
     "field 'shape': type 'polygon2' is not one of point, polygon, circle, number, choice, "
     "text; did you mean 'polygon'?", "fields ="),
    ('role = "commander"', 'role = "comander"',
     "role 'comander' is not one of commander, operator, observer; did you mean "
     "'commander'?", "role ="),
    ('label = "Exclusion zone"', 'lable = "Exclusion zone"',
     "unknown key 'lable'; did you mean 'label'?", "lable ="),
    ("max_vertices = 6", "max_vertices = 2", "max_vertices must be a whole number in "
     "[3, 1000]", "fields ="),
])
def test_a_bad_declaration_is_an_error_at_its_key(project: Path, old: str, new: str,
                                                  message: str, at: str) -> None:
    text = project.read_text()
    assert old in text
    project.write_text(text.replace(old, new))
    errors = check_project(load_file(project)).errors
    found = [f for f in errors if message in f.message]
    assert found, [f.message for f in errors]
    assert found[0].line == _line(project.read_text(), at), found[0]
    assert found[0].key is not None and found[0].key.startswith("operator.commands.exclusion")


def test_a_command_the_agent_has_no_plan_for_is_an_error(project: Path) -> None:
    text = project.read_text()
    assert not check_project(load_file(project)).errors
    project.write_text(text.replace(GOOD, 'percept = "exclusion_zon(Zone, Shape)"'))
    errors = check_project(load_file(project)).errors
    found = [f for f in errors if "exclusion_zon/2" in f.message]
    assert found and "did you mean 'exclusion_zone'" in found[0].message, found
    assert found[0].line == _line(text, GOOD)
    project.write_text(text.replace(GOOD, 'percept = "exclusion_zone(Zone)"').replace(
        '  { name = "shape", type = "polygon", max_vertices = 6 },\n', ""))
    errors = check_project(load_file(project)).errors
    assert any("exclusion_zone/1" in f.message and "another arity" in f.message
               for f in errors), [f.message for f in errors]
