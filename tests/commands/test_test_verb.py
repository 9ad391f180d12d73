"""`mrss test PROJECT`: the project's procedures under pytest, pytest's exit code passed on."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PROJECTS = ROOT / "tests" / "projects"


def mrss_test(*args: str, projects: Path = PROJECTS) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "mrss", "test", *args], cwd=ROOT,
                          env={**os.environ, "MRSS_PROJECTS": str(projects)},
                          capture_output=True, text=True, timeout=120)


def test_passing_procedure_exits_0() -> None:
    out = mrss_test("procs", "-k", "passing")
    assert out.returncode == 0, out.stdout + out.stderr
    assert "1 passed, 1 deselected" in out.stdout


def test_failing_procedure_exits_1_with_pytests_report() -> None:
    out = mrss_test("procs", "-k", "failing")
    assert out.returncode == 1
    assert "this procedure fails on purpose" in out.stdout
    assert "1 failed, 1 deselected" in out.stdout


def test_all_procedures_of_the_project_run_by_default() -> None:
    out = mrss_test("procs", "--", "-q")
    assert out.returncode == 1
    assert "1 failed, 1 passed" in out.stdout


def test_nothing_selected_is_pytests_exit_5() -> None:
    out = mrss_test("procs", "-k", "no_such_procedure")
    assert out.returncode == 5


def test_unknown_project_exits_2_listing_the_known_ones() -> None:
    out = mrss_test("nonesuch")
    assert out.returncode == 2
    assert "unknown project 'nonesuch'; known projects:" in out.stderr
    known = out.stderr.split("known projects:")[1]
    assert "procs" in known and "demo" in known


def test_project_without_procedures_exits_2() -> None:
    out = mrss_test("demo")
    assert out.returncode == 2
    assert "project 'demo' has no procedures/ folder" in out.stderr


def test_the_failing_procedure_stays_out_of_the_main_suite() -> None:
    env = {k: v for k, v in os.environ.items() if k not in ("MRSS_PROJECT", "MRSS_PROJECT_DIR")}
    out = subprocess.run([sys.executable, "-m", "pytest", "--collect-only", "-q",
                          str(PROJECTS / "procs")], cwd=ROOT, env=env, capture_output=True,
                         text=True, timeout=120)
    assert "test_failing_procedure" not in out.stdout
    assert out.returncode == 5  # nothing collected
