"""Project modules are imported from the project folder only, with clear errors otherwise."""

from __future__ import annotations

from pathlib import Path

import pytest

from mrss.actors.datalayer.layer import DataLayer
from mrss.actors.datalayer.service import load_datalayer_class
from mrss.actors.events.adapter import ExternalAdapter
from mrss.errors import ConfigError
from mrss.runtime.loader import import_project_module, load_project_class
from tests.edge.fixture_project import PROJECT_FIXTURE

ADAPTER = ("from mrss.api import ExternalAdapter\n"
           "class {name}(ExternalAdapter):\n    pass\n")


def test_fixture_project_classes_load() -> None:
    cls = load_project_class(PROJECT_FIXTURE, "events.py", ExternalAdapter)
    assert cls.__name__ == "FixtureAdapter" and issubclass(cls, ExternalAdapter)
    data_cls = load_datalayer_class(PROJECT_FIXTURE, {})
    assert data_cls.__name__ == "FixtureData"


@pytest.mark.parametrize("path", ["../outside.py", "sub/../../outside.py", "/etc/passwd.py"])
def test_paths_outside_the_project_are_refused(tmp_path: Path, path: str) -> None:
    project = tmp_path / "proj"
    project.mkdir()
    (tmp_path / "outside.py").write_text("raise SystemExit('must never run')\n")
    with pytest.raises(ConfigError, match="refused"):
        load_project_class(project, path, ExternalAdapter)


def test_symlink_pointing_out_of_the_project_is_refused(tmp_path: Path) -> None:
    project = tmp_path / "proj"
    project.mkdir()
    evil = tmp_path / "evil.py"
    evil.write_text(ADAPTER.format(name="Evil"))
    (project / "events.py").symlink_to(evil)
    with pytest.raises(ConfigError, match="outside the project"):
        load_project_class(project, "events.py", ExternalAdapter)


def test_symlink_inside_the_project_is_fine(tmp_path: Path) -> None:
    (tmp_path / "real_events.py").write_text(ADAPTER.format(name="Real"))
    (tmp_path / "events.py").symlink_to(tmp_path / "real_events.py")
    assert load_project_class(tmp_path, "events.py", ExternalAdapter).__name__ == "Real"


def test_missing_and_non_python_files(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="no such file"):
        load_project_class(tmp_path, "events.py", ExternalAdapter)
    (tmp_path / "events.txt").write_text("x")
    with pytest.raises(ConfigError, match="not a .py"):
        load_project_class(tmp_path, "events.txt", ExternalAdapter)


def test_syntax_and_import_errors_name_file_and_line(tmp_path: Path) -> None:
    (tmp_path / "events.py").write_text("x = 1\ndef broken(:\n")
    with pytest.raises(ConfigError, match=r"events\.py:2.*syntax error"):
        load_project_class(tmp_path, "events.py", ExternalAdapter)
    (tmp_path / "datalayer.py").write_text("import os\n\nraise RuntimeError('no db')\n")
    with pytest.raises(ConfigError, match=r"datalayer\.py:3.*RuntimeError: no db"):
        load_project_class(tmp_path, "datalayer.py", DataLayer)


def test_class_selection(tmp_path: Path) -> None:
    (tmp_path / "none.py").write_text("from mrss.api import ExternalAdapter\n")
    with pytest.raises(ConfigError, match="no subclass of ExternalAdapter"):
        load_project_class(tmp_path, "none.py", ExternalAdapter)
    (tmp_path / "two.py").write_text(ADAPTER.format(name="A") + ADAPTER.format(name="B")
                                     .replace("from mrss.api import ExternalAdapter\n",
                                              ""))
    with pytest.raises(ConfigError, match=r"several subclasses.*A, B"):
        load_project_class(tmp_path, "two.py", ExternalAdapter)
    assert load_project_class(tmp_path, "two.py", ExternalAdapter, class_name="B").__name__ \
        == "B"
    with pytest.raises(ConfigError, match="'C' is not a subclass"):
        load_project_class(tmp_path, "two.py", ExternalAdapter, class_name="C")


def test_each_import_is_a_fresh_module(tmp_path: Path) -> None:
    (tmp_path / "events.py").write_text("counter = []\ncounter.append(1)\n")
    first = import_project_module(tmp_path, "events.py")
    second = import_project_module(tmp_path, "events.py")
    assert first is not second and second.counter == [1]


def test_default_datalayer_when_the_project_has_none(tmp_path: Path) -> None:
    assert load_datalayer_class(tmp_path, {}) is DataLayer
    with pytest.raises(ConfigError, match="no such file"):
        load_datalayer_class(tmp_path, {"module": "datalayer.py"})
