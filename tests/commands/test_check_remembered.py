"""A clean check is remembered by what it read, so the start of an unchanged project
skips it, and nothing that could change its verdict is missed: a changed file (its
contents or its permission bits), a new file, another MRSS_ setting, another set of
environment variable names are each another key; a remembered pass never hides an
error made since (`mrss supervise` refuses it, through a real process)."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from mrss.check import passed
from mrss.testing import wait_until
from tests.commands.test_check_mistakes import MISTAKES, inject, project

__all__ = ["project"]  # the fixture: a copy of the template, as `flood`


@pytest.fixture(autouse=True)
def own_cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The user's cache folder, where clean checks are remembered: this test's own."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))


def test_the_key_follows_everything_the_check_reads(
        project: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    keys = {passed.key(project)}
    assert passed.key(project) in keys  # the same project: the same key
    agent = project / "agent.asl"
    agent.write_text(agent.read_text(encoding="utf-8") + "\n// a comment\n",
                     encoding="utf-8")
    keys.add(passed.key(project))
    agent.chmod(0o600)
    keys.add(passed.key(project))
    (project / "notes.json").write_text("{}", encoding="utf-8")
    keys.add(passed.key(project))
    monkeypatch.setenv("MRSS_SIM_SPEEDUP", "7")
    keys.add(passed.key(project))
    monkeypatch.setenv("A_TOKEN_THE_PROJECT_NAMES", "x")
    keys.add(passed.key(project))
    assert len(keys) == 6
    (project / "__pycache__").mkdir()
    (project / "__pycache__" / "x.pyc").write_bytes(b"\0")
    assert passed.key(project) in keys  # caches are not read by the check


def test_remembered_only_after_a_clean_check_of_the_same_project(project: Path) -> None:
    assert not passed.remembered(passed.key(project))
    passed.remember(project)
    assert passed.remembered(passed.key(project))
    inject(project, MISTAKES[0])
    assert not passed.remembered(passed.key(project))


def start(project: Path, run: Path) -> subprocess.CompletedProcess[str]:
    """`mrss supervise` of the project: refused (an error), or run until every
    component started, then interrupted (SIGINT, as Ctrl-C)."""
    proc = subprocess.Popen([sys.executable, "-m", "mrss", "supervise", "flood",
                             "--no-tui", "--run-dir", str(run)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=dict(os.environ))
    try:
        wait_until(lambda: proc.poll() is not None or (
            (run / "mrss.log").is_file() and "start reasoner" in
            (run / "mrss.log").read_text(encoding="utf-8")), timeout=120,
            message="the project refused or running")
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    return subprocess.CompletedProcess(proc.args, proc.returncode, out, err)


SKIPPED = "check skipped: an earlier start checked the project as it is now"


@pytest.mark.slow
def test_a_second_start_skips_the_check_and_a_remembered_pass_hides_no_error(
        project: Path) -> None:
    run = project.parent / "run"
    first = start(project, run)
    assert first.returncode == 0, first.stderr
    assert SKIPPED not in (run / "mrss.log").read_text(encoding="utf-8")
    shutil.rmtree(run)
    second = start(project, run)
    assert second.returncode == 0, second.stderr
    assert SKIPPED in (run / "mrss.log").read_text(encoding="utf-8")
    shutil.rmtree(run)
    inject(project, MISTAKES[0])  # a mistake made since: checked, and refused
    out = start(project, run)
    assert out.returncode == 2, out.stderr
    assert "shutdwon" in out.stderr and "not started" in out.stderr
