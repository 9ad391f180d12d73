"""mrss.api is the whole contract: projects import nothing else, and it names what they need."""

from __future__ import annotations

import ast
import re
from pathlib import Path
from types import ModuleType

import pytest

import mrss.api
import mrss.api.testing

REPO = Path(__file__).resolve().parents[2]
PROJECT_FILES = sorted((REPO / "projects").rglob("*.py"))


def mrss_imports(path: Path) -> list[tuple[int, str]]:
    """(line, module) of every import of an mrss module in `path`."""
    found: list[tuple[int, str]] = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
        if isinstance(node, ast.Import):
            found += [(node.lineno, a.name) for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            found.append((node.lineno, node.module))
    return [(line, m) for line, m in found if m == "mrss" or m.startswith("mrss.")]


def outside_contract(path: Path, root: Path = REPO) -> list[str]:
    return [f"{path.relative_to(root)}:{line}: imports {module}"
            for line, module in mrss_imports(path)
            if module != "mrss.api" and not module.startswith("mrss.api.")]


def test_every_project_file_imports_only_mrss_api() -> None:
    assert PROJECT_FILES, "no project files found"
    problems = [p for path in PROJECT_FILES for p in outside_contract(path)]
    assert not problems, "\n".join(problems)


def test_the_import_check_catches_an_internal_import(tmp_path: Path) -> None:
    bad = tmp_path / "rcl.py"
    bad.write_text("from mrss.api import Skill\nimport mrss.config.loader\n"
                   "from mrss.links.geo import offset\n", encoding="utf-8")
    assert outside_contract(bad, tmp_path) == ["rcl.py:2: imports mrss.config.loader",
                                               "rcl.py:3: imports mrss.links.geo"]


@pytest.mark.parametrize("module", [mrss.api, mrss.api.testing])
def test_every_exported_name_exists_and_is_documented(module: ModuleType) -> None:
    names = module.__all__
    assert len(set(names)) == len(names)
    doc = module.__doc__ or ""
    for name in names:
        assert hasattr(module, name), name
        if module is mrss.api:
            assert name in doc or name == "SKILL_TRANSITIONS", f"{name} not in the module doc"


def test_rcl_internals_are_not_part_of_the_contract() -> None:
    for internal in ("ACTION_TRANSITIONS", "check_json", "check_action_transition",
                     "SkillRuntime", "bind_runtime"):
        assert internal not in mrss.api.__all__


def test_what_a_project_needs_is_in_the_contract() -> None:
    needed = {"Action", "ActionState", "RobotCommLayer", "Skill", "SkillOutcome", "Resource",
              "CriticalSection",
              "DataLayer", "external", "ExternalAdapter", "Field", "JsonMapping", "Atom",
              "create_link", "connect_link", "RobotLink", "LinkError", "distance_m", "offset",
              "step_towards", "ActionError", "ConfigError", "TransientError", "PROJECT_FILE",
              "import_project_module", "project_broker_url", "BROKER_URL_FILE",
              "publish_json", "Bid", "Evaluator", "Task"}
    assert needed <= set(mrss.api.__all__)
    assert {"ScriptedHost", "RunningProject", "wait_until"} <= set(mrss.api.testing.__all__)


# -- the configuration contract: project.toml names components by kind ----------------------
INTERNAL_PATH = re.compile(r"""(?<![\w.])(mrss\.[A-Za-z_][\w.]*:[A-Za-z_]\w*)""")
CONFIG_FILES = sorted([*(REPO / "projects").rglob("project.toml"),
                       *(REPO / "tests").rglob("project.toml"),
                       *(REPO / "tests").rglob("project.toml.in"),
                       *(REPO / "docs").glob("*.md"), REPO / "README.md"])


def internal_paths(path: Path, root: Path = REPO) -> list[str]:
    """file:line of every `mrss.<module>:<Class>` a configuration file or doc names."""
    return [f"{path.relative_to(root)}:{n}: {m.group(1)}"
            for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
            for m in INTERNAL_PATH.finditer(line)]


def test_no_project_test_project_or_doc_names_an_internal_module_path() -> None:
    assert len(CONFIG_FILES) > 20, "the shipped and test projects were not found"
    problems = [p for path in CONFIG_FILES for p in internal_paths(path)]
    assert not problems, "name the component by kind (config/kinds.py):\n" + "\n".join(problems)


def test_the_path_check_catches_a_module_line(tmp_path: Path) -> None:
    toml = tmp_path / "project.toml"
    toml.write_text('[components.rcl]\nmodule = "mrss.actors.rcl_service:RclService"\n'
                    '[components.own]\nmodule = "beacon:Beacon"\n', encoding="utf-8")
    assert internal_paths(toml, tmp_path) == [
        "project.toml:2: mrss.actors.rcl_service:RclService"]
