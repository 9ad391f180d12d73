"""`mrss check`: mistakes that cross files (mrss/check/cross_file.py), one error each.

Each case copies a bundled project, changes what one file states about another (or the
other file under it) and runs `mrss check --json` in process: exit 2, exactly one error,
at the file and line that states the fact. The single-file variants of these rules are
cases of tests/commands/test_check_mistakes.py.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

import pytest

from mrss.check.cross_file import RULES
from mrss.cli import main

PROJECTS = Path(__file__).resolve().parents[2] / "projects"


def copy(name: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    folder = tmp_path / "projects" / name
    shutil.copytree(PROJECTS / name, folder, ignore=shutil.ignore_patterns("__pycache__"))
    monkeypatch.setenv("MRSS_PROJECTS", str(folder.parent))
    return folder


def edit(path: Path, old: str, new: str) -> None:
    text = path.read_text(encoding="utf-8")
    assert text.count(old) == 1, f"{old!r} not unique in {path.name}"
    path.write_text(text.replace(old, new), encoding="utf-8")


def line_of(path: Path, marker: str) -> int:
    lines = path.read_text(encoding="utf-8").splitlines()
    found = [n for n, line in enumerate(lines, start=1) if marker in line]
    assert len(found) == 1, f"marker {marker!r} on lines {found}"
    return found[0]


def one_error(project: str, capsys: pytest.CaptureFixture[str]) -> dict[str, Any]:
    code = main(["check", project, "--json"])
    report = json.loads(capsys.readouterr().out)
    errors = [f for f in report["findings"] if f["severity"] == "error"]
    assert code == 2 and len(errors) == 1, errors
    return dict(errors[0])


@pytest.fixture()
def template(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    return copy("template", tmp_path, monkeypatch)


def test_a_procedure_that_does_not_compile_is_an_error_at_its_line(
        template: Path, capsys: pytest.CaptureFixture[str]) -> None:
    procedure = template / "procedures" / "test_template.py"
    edit(procedure, "def test_operator_goal_is_reached(",
         "def broken(:\n    pass\n\n\ndef test_operator_goal_is_reached(")
    error = one_error("template", capsys)
    assert (error["file"], error["line"]) == (str(procedure), line_of(procedure, "broken(:"))
    assert error["message"].startswith("syntax error")
    assert error["col"] > 0 and "^" in error["detail"]


def test_return_outside_a_function_counts_as_not_compiling(
        template: Path, capsys: pytest.CaptureFixture[str]) -> None:
    helper = template / "helper.py"  # parsed by ast it is fine; compiling it is not
    helper.write_text('"""A helper script."""\n\nreturn 3\n', encoding="utf-8")
    error = one_error("template", capsys)
    assert (error["file"], error["line"]) == (str(helper), 3)
    assert "'return' outside function" in error["message"]


def test_a_procedure_naming_what_a_project_file_lacks(
        template: Path, capsys: pytest.CaptureFixture[str]) -> None:
    procedure = template / "procedures" / "test_events_named.py"
    procedure.write_text(
        "from pathlib import Path\n\nfrom mrss.api import import_project_module\n\n"
        'events = import_project_module(Path(__file__).resolve().parent.parent, "events.py")\n'
        "\n\ndef test_adapter() -> None:\n    assert events.ProjectEvnts.OPTIONS\n",
        encoding="utf-8")
    error = one_error("template", capsys)
    assert (error["file"], error["line"]) == (str(procedure), 9)
    assert error["col"] == len("    assert events.") + 1
    assert error["message"] == ("events.ProjectEvnts: events.py defines no 'ProjectEvnts'; "
                                "did you mean 'ProjectEvents'?")


def test_a_procedure_loading_a_file_the_project_lacks(
        template: Path, capsys: pytest.CaptureFixture[str]) -> None:
    procedure = template / "procedures" / "test_sensors.py"
    procedure.write_text(
        "from pathlib import Path\n\nfrom mrss.api import import_project_module\n\n"
        "PROJECT = Path(__file__).resolve().parent.parent\n"
        'sensors = import_project_module(PROJECT, "sensors.py")\n', encoding="utf-8")
    error = one_error("template", capsys)
    assert (error["file"], error["line"]) == (str(procedure), line_of(procedure, "sensors.py"))
    assert "import_project_module(..., 'sensors.py'): no such file" in error["message"]


def test_an_adapter_class_renamed_under_its_configured_name(
        template: Path, capsys: pytest.CaptureFixture[str]) -> None:
    edit(template / "events.py", "class ProjectEvents(ExternalAdapter):",
         "class FloodEvents(ExternalAdapter):")
    toml = template / "project.toml"
    edit(toml, "[events]", '[events]\nclass = "ProjectEvents"\n#')
    code = main(["check", "template", "--json"])
    findings = json.loads(capsys.readouterr().out)["findings"]
    errors = [f for f in findings if f["severity"] == "error"]
    assert code == 2 and len(errors) == 1, findings
    assert (errors[0]["file"], errors[0]["line"]) == (str(toml), line_of(toml, "ProjectEvents"))
    assert "defines the ExternalAdapter subclasses: FloodEvents" in errors[0]["message"]
    # what was not checked because of it names where the error is, not events.py
    skipped = [f["message"] for f in findings if "options not checked" in f["message"]]
    assert skipped == ["[events] options not checked: its class (events.class in "
                       "project.toml) has an error reported above"]


def test_a_data_layer_function_returning_what_no_term_holds(
        template: Path, capsys: pytest.CaptureFixture[str]) -> None:
    edit(template / "datalayer.py", "lat: float, lon: float) -> float:",
         "lat: float, lon: float) -> dict[str, float]:")
    agent = template / "agent.asl"
    reached = '      .print("goal ", G, " reached");'
    edit(agent, reached, "      query(distance_to, [R, Lat, Lon], D);\n" + reached)
    error = one_error("template", capsys)
    assert (error["file"], error["line"]) == (str(agent), line_of(agent, "query(distance_to"))
    assert "declared to return dict" in error["message"]
    assert "which no AgentSpeak term can hold" in error["message"]


def test_a_data_layer_function_whose_result_no_plan_takes(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    amadee = copy("amadee", tmp_path, monkeypatch)
    edit(amadee / "datalayer.py", "def legal(self, action: str) -> list[str]:",
         "def legal(self, action: str) -> str:")
    error = one_error("amadee", capsys)
    agent = amadee / "agent.asl"
    assert (error["file"], error["line"]) == (str(agent), line_of(agent, "query(legal, [A], V);"))
    assert "expects a list (passed to !decide/3, whose plans" in error["message"]
    assert "returns a string (str)" in error["message"]


def test_the_cross_file_rules_are_one_table() -> None:
    names = [name for name, _ in RULES]
    assert names == ["robot ids", "roles", "query fit", "python refs and compiles"]
