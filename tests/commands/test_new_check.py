"""`mrss new` and `mrss check` as a user runs them: real processes on a projects folder."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest


def mrss(projects: Path, *args: str) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, MRSS_PROJECTS=str(projects))
    return subprocess.run([sys.executable, "-m", "mrss", *args], capture_output=True,
                          text=True, timeout=60, env=env)


@pytest.fixture()
def projects(tmp_path: Path) -> Path:
    folder = tmp_path / "projects"
    folder.mkdir()
    return folder


@pytest.fixture()
def fresh(projects: Path) -> Path:
    """A project made by `mrss new field` from the bundled template."""
    out = mrss(projects, "new", "field")
    assert out.returncode == 0, out.stderr
    return projects / "field"


def test_new_copies_the_template_and_renames_it(projects: Path) -> None:
    out = mrss(projects, "new", "field")
    assert out.returncode == 0, out.stderr
    folder = projects / "field"
    for name in ("project.toml", "agent.asl", "events.py", "rcl.py", "skills.py",
                 "datalayer.py"):
        assert (folder / name).is_file(), name
    assert (folder / "procedures" / "test_field.py").is_file()
    assert not (folder / "procedures" / "test_template.py").exists()
    assert re.search(r'^name = "field"', (folder / "project.toml").read_text(), re.M)
    assert not list(folder.rglob("__pycache__"))
    assert "mrss check field" in out.stdout

    check = mrss(projects, "check", "field")
    assert check.returncode == 0, check.stderr
    assert "field: OK" in check.stdout
    assert "agent agent.asl:" in check.stdout and "robots: robot1" in check.stdout


@pytest.mark.slow
def test_new_refuses_existing_folders_bad_names_and_unknown_sources(fresh: Path) -> None:
    projects = fresh.parent
    before = sorted(p.name for p in fresh.rglob("*"))
    again = mrss(projects, "new", "field")
    assert again.returncode == 2
    assert "already exists" in again.stderr
    assert sorted(p.name for p in fresh.rglob("*")) == before  # untouched

    for bad in ("Field", "1field", "a-b", "../up", "x" * 65):
        out = mrss(projects, "new", bad)
        assert out.returncode == 2, bad
        assert "not a valid project name" in out.stderr
    assert sorted(p.name for p in projects.iterdir()) == ["field"]

    unknown = mrss(projects, "new", "other", "--from", "nosuch")
    assert unknown.returncode == 2
    assert "unknown project 'nosuch'" in unknown.stderr and "field" in unknown.stderr

    copy = mrss(projects, "new", "second", "--from", "field")   # from a project of mine
    assert copy.returncode == 0, copy.stderr
    assert (projects / "second" / "procedures" / "test_second.py").is_file()


def test_check_reports_every_agent_syntax_error_with_file_line_col(fresh: Path) -> None:
    agent = fresh / "agent.asl"
    lines = agent.read_text().splitlines()
    lines[15:15] = ["ok(1) ok(2).", "fine(1).", "+!also : <- true."]
    agent.write_text("\n".join(lines) + "\n")
    out = mrss(fresh.parent, "check", "field")
    assert out.returncode == 2
    locations = re.findall(rf"{re.escape(str(agent))}:(\d+):(\d+):", out.stderr)
    assert len(locations) >= 2, out.stderr
    assert {int(line) for line, _ in locations} >= {16, 18}
    assert re.search(r"^\s+\^$", out.stderr, re.M)      # a caret under the column
    assert "error(s)" in out.stderr


@pytest.mark.parametrize(("file", "text", "expected"), [
    ("events.py", "\n\nclass Broken(:\n", r"events\.py:\d+:\d+: syntax error"),
    ("rcl.py", "\nraise RuntimeError('no robots here')\n", r"rcl\.py:\d+.*no robots here"),
    ("skills.py", "\n\nfrom nowhere import Nothing\n", r"skills\.py:\d+.*nowhere"),
    ("datalayer.py", "\nclass Second(DataLayer):\n    pass\n", r"datalayer\.py.*Second"),
])
def test_check_reports_python_errors_with_file_and_line(fresh: Path, file: str, text: str,
                                                        expected: str) -> None:
    path = fresh / file
    path.write_text(path.read_text() + text)
    out = mrss(fresh.parent, "check", "field")
    assert out.returncode == 2, out.stdout
    assert re.search(str(fresh) + "/" + expected, out.stderr), out.stderr


def test_check_validates_robots_and_links(fresh: Path) -> None:
    toml = fresh / "project.toml"
    text = toml.read_text().replace(
        "[components.rcl.robots.robot1]",
        '[components.rcl.robots.Robot2]\nlink = "mavlink"\nurl = 14550\n'
        'colour = "red"\n\n[components.rcl.robots.robot3]\nlink = "carrier-pigeon"\n\n'
        "[components.rcl.robots.robot1]")
    toml.write_text(text)
    out = mrss(fresh.parent, "check", "field")
    assert out.returncode == 2
    err = out.stderr
    numbered = {n: i + 1 for i, n in enumerate(text.splitlines())}
    assert f"project.toml:{numbered['[components.rcl.robots.Robot2]']}: key " \
           "'components.rcl.robots.Robot2': a robot id must be a lowercase identifier" in err
    assert f"project.toml:{numbered['url = 14550']}: key 'components.rcl.robots.Robot2.url'" \
           ": must be of type str" in err
    assert "'components.rcl.robots.Robot2.colour': not a mavlink link option" in err
    assert "unknown link kind 'carrier-pigeon'" in err


def test_check_unknown_project_exits_2_listing_known_ones(fresh: Path) -> None:
    out = mrss(fresh.parent, "check", "nosuch")
    assert out.returncode == 2
    assert "unknown project 'nosuch'" in out.stderr
    assert "known projects: field" in out.stderr


def test_bundled_projects_pass_check() -> None:
    root = Path(__file__).resolve().parents[2] / "projects"
    for name in ("template", "template_sims", "wildfire", "amadee"):
        out = mrss(root, "check", name)
        assert out.returncode == 0, out.stderr
        assert f"{name}: OK" in out.stdout
