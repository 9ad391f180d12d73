"""project.toml loading and validation, and `mrss check`."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from mrss.config import load_file, load_project
from mrss.errors import ConfigError
from mrss.supervision.spec import KILL, OnExceeded, Restart, Strategy

PROJECTS = Path(__file__).resolve().parent.parent / "projects"


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "project.toml"
    path.write_text(text)
    return path


def test_demo_project_loads_with_every_key() -> None:
    cfg = load_project("demo", PROJECTS)
    assert cfg.name == "demo" and cfg.description == "three workers under one_for_one"
    spec = cfg.supervisor.spec
    assert spec.strategy is Strategy.ONE_FOR_ONE and spec.intensity == 3 and spec.period == 10.0
    assert spec.backoff.initial == 0.05 and spec.backoff.cap == 0.5 and spec.backoff.jitter == 0.1
    assert cfg.supervisor.heartbeat_interval == 0.1 and cfg.supervisor.heartbeat_misses == 3
    assert [c.id for c in cfg.components] == ["alpha", "beta", "gamma", "off"]
    assert [s.id for s in cfg.child_specs()] == ["alpha", "beta", "gamma"]
    beta = cfg.components[1]
    assert beta.options == {"grandchild": True} and beta.restart is Restart.PERMANENT
    assert cfg.components[2].shutdown == KILL and cfg.components[2].restart is Restart.TRANSIENT
    assert cfg.child_specs()[1].start.options == {"grandchild": True}


def test_defaults_apply_when_tables_are_absent(tmp_path: Path) -> None:
    cfg = load_file(write(tmp_path, '[components.a]\nmodule = "x.y:Z"\n'))
    assert cfg.name == tmp_path.name
    assert cfg.supervisor.spec.on_exceeded is OnExceeded.ESCALATE
    assert cfg.supervisor.launcher == "fork"
    (a,) = cfg.components
    assert (a.shutdown, a.start_timeout, a.enabled, a.options) == (5.0, 10.0, True, {})


@pytest.mark.parametrize(("text", "key", "line", "fragment"), [
    ('[supervisor]\nstrategy = "all"\n', "supervisor.strategy", 2, "must be one of"),
    ('[supervisor]\nintensty = 3\n', "supervisor.intensty", 2, "did you mean 'intensity'"),
    ('[supervisor]\nperiod = -1\n', "supervisor.period", 2, ">= 0"),
    ('[supervisor]\nperiod = 0\n', "supervisor", 1, "period must be > 0"),
    ('[supervisor.backoff]\nfactor = 0.5\n', "supervisor.backoff", 1, "factor must be >= 1"),
    ('[supervisor]\nlauncher = "spawn"\n', "supervisor.launcher", 2, "'fork' or 'exec'"),
    ('[supervisor]\nheartbeat_misses = 0\n', "supervisor.heartbeat_misses", 2, ">= 1"),
    ('[supervisor]\nstrategy = "one_for_all"\non_exceeded = "quarantine"\n', "supervisor", 1,
     "quarantine"),
    ('[components.a]\nrestart = "permanent"\n', "components.a.module", 1, "required"),
    ('[components.a]\nmodule = "nocolon"\n', "components.a.module", 2, "dotted.module:Class"),
    ('\n[components.a]\nmodule = "a:B"\nrestart = "sometimes"\n', "components.a.restart", 4,
     "permanent, transient, temporary"),
    ('[components.a]\nmodule = "a:B"\nshutdown = "never"\n', "components.a.shutdown", 3,
     "'kill'"),
    ('[components.a]\nmodule = "a:B"\nenabled = "yes"\n', "components.a.enabled", 3,
     "must be bool"),
    ('[components."9lives"]\nmodule = "a:B"\n', "components.9lives", None, "starts with a letter"),
    ('components = 3\n', "components", 1, "table"),
])
def test_bad_keys_name_file_line_and_key(
        tmp_path: Path, text: str, key: str, line: int | None, fragment: str) -> None:
    path = write(tmp_path, text)
    with pytest.raises(ConfigError) as info:
        load_file(path)
    err = info.value
    assert err.key == key
    assert err.file == (f"{path}:{line}" if line else str(path)) or \
        (line is None and err.file.startswith(str(path)))
    assert fragment in str(err)


def test_toml_syntax_errors_name_the_file_and_line(tmp_path: Path) -> None:
    path = write(tmp_path, "[supervisor\nstrategy = 1\n")
    with pytest.raises(ConfigError, match=r"not valid TOML: .*line 1") as info:
        load_file(path)
    assert info.value.file == str(path)


def test_unknown_tables_are_kept_and_near_miss_options_warned(tmp_path: Path) -> None:
    cfg = load_file(write(tmp_path, '[robots.uav1]\nlink = "mavlink"\n[supervsior]\nx = 1\n'
                                    '[components.a]\nmodule = "a:B"\nrestarts = 1\n'))
    assert cfg.sections["robots"] == {"uav1": {"link": "mavlink"}}
    assert any("[supervsior]" in w for w in cfg.warnings)
    assert not any("[robots]" in w for w in cfg.warnings)
    assert any("did you mean 'restart'" in w for w in cfg.warnings)
    assert cfg.components[0].options == {"restarts": 1}


def run_check(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "mrss", "check", *args], capture_output=True,
                          text=True, timeout=60,
                          env={**os.environ, "MRSS_PROJECTS": str(PROJECTS)})


def test_check_prints_a_summary_and_exits_zero() -> None:
    result = run_check("demo")
    assert result.returncode == 0, result.stderr
    assert "project demo:" in result.stdout
    assert "gamma            tests.projects.workers:Worker  transient, shutdown kill" \
        in result.stdout
    assert "(disabled)" in result.stdout


def test_check_reports_file_line_and_key_and_exits_two() -> None:
    result = run_check("broken")
    assert result.returncode == 2
    assert result.stderr.strip() == (
        f"mrss check: {PROJECTS / 'broken' / 'project.toml'}:7: key 'components.alpha.restart': "
        "must be one of permanent, transient, temporary, not 'sometimes'")


def test_check_imports_component_classes(tmp_path: Path) -> None:
    (tmp_path / "p").mkdir()
    (tmp_path / "p" / "project.toml").write_text(
        '[components.a]\nmodule = "tests.projects.workers:NotAComponent"\n')
    result = subprocess.run([sys.executable, "-m", "mrss", "check", "p"], capture_output=True,
                            text=True, timeout=60,
                            env={**os.environ, "MRSS_PROJECTS": str(tmp_path)})
    assert result.returncode == 2
    assert "key 'components.a.module'" in result.stderr
    assert "is not a subclass of mrss Component" in result.stderr


def test_check_unknown_project_lists_known_ones() -> None:
    result = run_check("nope")
    assert result.returncode == 2
    assert "unknown project 'nope'" in result.stderr and "demo" in result.stderr
