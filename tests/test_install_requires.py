"""The run install (`make run`: `pip install -e .`, no dev extra) has what MRSS imports.

Every third-party module imported by `mrss/`, by the projects (their components and their
procedures) and the module `mrss test` runs in its child process (pytest) must come
from a distribution in setup.cfg's `install_requires`: `mrss test PROJECT` after
`make run` used to fail with `No module named pytest`. The check reads the code (every
import statement, at any depth) and setup.cfg, and maps modules to distributions
through the installed metadata.
"""

from __future__ import annotations

import ast
import configparser
import importlib.metadata
import re
import sys
from collections.abc import Iterator
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
TEST_VERB = ROOT / "mrss" / "commands" / "test.py"
REQUIREMENT_NAME = re.compile(r"^\s*([A-Za-z0-9][A-Za-z0-9._-]*)")


def normalized(distribution: str) -> str:
    return re.sub(r"[-_.]+", "-", distribution).lower()


def install_requires() -> set[str]:
    """The distributions the run install brings (their names, normalized)."""
    cfg = configparser.ConfigParser()
    cfg.read(ROOT / "setup.cfg", encoding="utf-8")
    names = set()
    for line in cfg["options"]["install_requires"].splitlines():
        match = REQUIREMENT_NAME.match(line)
        if match and not line.strip().startswith("#"):
            names.add(normalized(match.group(1)))
    return names


def imported(path: Path) -> Iterator[tuple[str, int]]:
    """The top-level module of every absolute import in `path`, with its line."""
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name.partition(".")[0], node.lineno
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            yield node.module.partition(".")[0], node.lineno


def launched_modules(path: Path) -> Iterator[tuple[str, int]]:
    """The modules a file starts as child processes: `python_module("NAME", ...)`."""
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
        if (isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
                and node.func.id == "python_module" and node.args
                and isinstance(node.args[0], ast.Constant)
                and isinstance(node.args[0].value, str)):
            yield node.args[0].value.partition(".")[0], node.lineno


def third_party(paths: list[Path], local: set[str]) -> dict[str, list[str]]:
    """Module -> where it is used, for modules neither stdlib, MRSS nor project-local."""
    found: dict[str, list[str]] = {}
    for path in paths:
        uses = [*imported(path), *(launched_modules(path) if path == TEST_VERB else ())]
        for module, line in uses:
            if module in sys.stdlib_module_names or module == "mrss" or module in local:
                continue
            found.setdefault(module, []).append(f"{path.relative_to(ROOT)}:{line}")
    return found


def undeclared(found: dict[str, list[str]]) -> list[str]:
    declared = install_requires()
    owners = importlib.metadata.packages_distributions()
    missing = []
    for module, where in sorted(found.items()):
        dists = {normalized(d) for d in owners.get(module, [])}
        if not dists & declared:
            missing.append(f"{module} (from {sorted(dists) or 'no installed distribution'}),"
                           f" imported at {', '.join(where[:3])}")
    return missing


def test_mrss_and_its_projects_import_only_what_the_run_install_declares() -> None:
    paths = sorted((ROOT / "mrss").rglob("*.py")) + sorted((ROOT / "projects").rglob("*.py"))
    local = {p.stem for p in (ROOT / "projects").rglob("*.py")}  # import_project_module's
    missing = undeclared(third_party(paths, local))
    assert not missing, "not in setup.cfg install_requires:\n" + "\n".join(missing)


def test_the_test_verb_runs_pytest_from_the_run_install() -> None:
    launched = {module for module, _ in launched_modules(TEST_VERB)}
    assert launched == {"pytest"}  # what `mrss test` starts; the check above covers it
    assert "pytest" in install_requires()


def test_the_check_sees_an_undeclared_import(tmp_path: Path) -> None:
    module = ROOT / "mrss" / "cli.py"  # any file of ours; only its imports are read here
    found = third_party([module], set())
    found["hypothesis"] = ["mrss/made_up.py:1"]  # a dev-only tool imported at run time
    assert undeclared(found) == [
        "hypothesis (from ['hypothesis']), imported at mrss/made_up.py:1"]
