"""Every process MRSS starts imports its own `mrss`, whatever folder it is started from.

A folder named `mrss` in the working directory (a checkout of this repository, which
Python sees as a namespace package, or another package of that name) used to shadow
the installed MRSS in every child started with `python -m`: the components crash-looped
with `ImportError ... mrss.projects (unknown location)` while `mrss check` passed.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import tomllib
from collections.abc import Callable
from pathlib import Path

import pytest

import mrss
from mrss.bus import Publisher, Subscriber
from mrss.bus.settings import endpoints_from_config
from mrss.interpreter import python_module
from mrss.messages import Command, SupEvent
from mrss.procedures import RunningProject
from mrss.testing import WaitTimeout, wait_until

ROOT = Path(__file__).resolve().parents[2]
TEMPLATE = ROOT / "projects" / "template"


def checkout(cwd: Path) -> None:
    """`mrss` is this repository's checkout (no __init__.py: a namespace package)."""
    (cwd / "mrss").symlink_to(ROOT, target_is_directory=True)


def other_package(cwd: Path) -> None:
    """`mrss` is some other package of that name, with modules named like ours."""
    (cwd / "mrss").mkdir()
    for module in ("__init__", "supervision", "bus"):
        (cwd / "mrss" / f"{module}.py").write_text('"""Not MRSS."""\nNOT_MRSS = True\n')


# as a user runs MRSS: tests/conftest.py puts the repository on PYTHONPATH, where it
# would come before a namespace portion in the working directory
USER_ENV = {**os.environ, "PYTHONPATH": ""}

SHADOWS: dict[str, Callable[[Path], None]] = {
    "checkout": checkout, "other_package": other_package}


@pytest.fixture(params=sorted(SHADOWS))
def shadowed_cwd(request: pytest.FixtureRequest, tmp_path: Path,
                 monkeypatch: pytest.MonkeyPatch) -> Path:
    """A working directory holding a folder named `mrss` that is not the installed MRSS."""
    cwd = tmp_path / "cwd"
    cwd.mkdir()
    SHADOWS[request.param](cwd)
    monkeypatch.chdir(cwd)
    return cwd


def test_python_module_imports_the_installed_mrss_from_a_shadowed_cwd(
        shadowed_cwd: Path) -> None:
    done = subprocess.run(python_module("mrss", "--version"), capture_output=True, text=True,
                          env=USER_ENV, timeout=60, check=False)
    assert done.returncode == 0, done.stderr
    assert mrss.__version__ in done.stdout


def running_children(run_dir: Path, expected: set[str], timeout: float) -> dict[str, str]:
    """Ask the root for its tree (`ctl.tree`) until every expected child is running."""
    endpoints = endpoints_from_config({}, run_dir)
    answers: list[SupEvent] = []
    sub = Subscriber(endpoints, prefixes=["sup.tree"])
    sub.start(lambda env: answers.append(env.body) if isinstance(env.body, SupEvent) else None)
    try:
        with Publisher(endpoints, src="test") as pub:
            def all_running() -> dict[str, str] | None:
                pub.publish(Command(command="tree"))
                if not answers:
                    return None
                kids = answers[-1].detail["tree"]["children"]  # type: ignore[index]
                states = {str(k["id"]): str(k["state"]) for k in kids}  # type: ignore[index]
                running = {c for c, state in states.items() if state == "running"}
                return states if running >= expected else None
            return wait_until(all_running, timeout, interval=0.2,
                              message=f"{sorted(expected)} running")
    finally:
        sub.close()


@pytest.mark.slow
@pytest.mark.parametrize("launcher", ["fork", "exec"])
def test_supervise_from_a_folder_holding_an_mrss_starts_every_component(
        shadowed_cwd: Path, tmp_path: Path, launcher: str) -> None:
    project = tmp_path / "projects" / "template"
    shutil.copytree(TEMPLATE, project, ignore=shutil.ignore_patterns("__pycache__"))
    toml = project / "project.toml"
    toml.write_text(toml.read_text().replace(
        "[supervisor]", f'[supervisor]\nlauncher = "{launcher}"', 1))
    components = set(tomllib.loads(toml.read_text())["components"])
    system = RunningProject(project, tmp_path / "run", env={"PYTHONPATH": ""})
    try:
        system.start(timeout=60)  # the bus proxy: a component, crash-looping when shadowed
        try:
            running_children(system.run_dir, components, timeout=60)
        except WaitTimeout:
            raise AssertionError(system.output.read_text()) from None
        assert system.interrupt() == 0
    finally:
        system.close()
