"""project.toml loading and validation, and `mrss check`."""

from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

from mrss.config.loader import load_file, load_project
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
    assert cfg.supervisor.heartbeat_interval == 0.1 and cfg.supervisor.heartbeat_misses == 50
    assert [c.id for c in cfg.components] == ["alpha", "beta", "gamma", "off"]
    assert [s.id for s in cfg.child_specs()] == ["alpha", "beta", "gamma"]
    beta = cfg.components[1]
    assert beta.options == {"grandchild": True} and beta.restart is Restart.PERMANENT
    assert cfg.components[2].shutdown == KILL and cfg.components[2].restart is Restart.TRANSIENT
    assert cfg.child_specs()[1].start.options == {"grandchild": True}


def test_defaults_apply_when_tables_are_absent(tmp_path: Path) -> None:
    cfg = load_file(write(tmp_path, '[components.a]\nmodule = "x.y:Z"\n'))
    assert cfg.name == tmp_path.name
    spec = cfg.supervisor.spec
    # a component over its budget is stopped alone and retried after a minute
    assert spec.on_exceeded is OnExceeded.QUARANTINE and spec.probation == 60.0
    assert spec.shared_intensity is None and spec.groups == () and spec.healthy_after == 10.0
    assert cfg.supervisor.launcher == "fork"
    (a,) = cfg.components
    assert (a.shutdown, a.start_timeout, a.enabled, a.options) == (5.0, 10.0, True, {})
    assert a.backoff


def test_give_up_retry_groups_and_shared_window_are_read(tmp_path: Path) -> None:
    cfg = load_file(write(tmp_path, """
[supervisor]
on_give_up = "stop_system"
retry_after = "never"
shared_intensity = 20

[supervisor.groups]
infrastructure = ["bus", "wm"]
robots = { children = ["sim", "off"], intensity = 2, period = 60 }

[components.bus]
kind = "bus"
[components.wm]
module = "a:B"
[components.sim]
module = "a:B"
backoff = false
[components.off]
module = "a:B"
enabled = false
"""))
    spec = cfg.supervisor.spec
    assert spec.on_exceeded is OnExceeded.ESCALATE and spec.probation == math.inf
    assert spec.shared_intensity == 20
    assert [(g.name, g.children, g.intensity, g.period) for g in spec.groups] == [
        ("infrastructure", ("bus", "wm"), 1, None),  # the group restarts once per period
        ("robots", ("sim",), 2, 60.0)]  # disabled ones left out
    # the bus proxy restarts without backoff unless told otherwise
    assert [c.backoff for c in cfg.child_specs()] == [False, True, False]


@pytest.mark.parametrize(("text", "key", "line", "fragment"), [
    ('[supervisor]\nstrategy = "all"\n', "supervisor.strategy", 2, "must be one of"),
    ('[supervisor]\nintensty = 3\n', "supervisor.intensty", 2, "did you mean 'intensity'"),
    ('[supervisor]\nperiod = -1\n', "supervisor.period", 2, ">= 0"),
    ('[supervisor]\nperiod = 0\n', "supervisor", 1, "period must be > 0"),
    ('[supervisor.backoff]\nfactor = 0.5\n', "supervisor.backoff", 1, "factor must be >= 1"),
    ('[supervisor]\nlauncher = "spawn"\n', "supervisor.launcher", 2, "'fork' or 'exec'"),
    ('[supervisor]\nheartbeat_misses = 0\n', "supervisor.heartbeat_misses", 2, ">= 1"),
    ('[supervisor]\ncpu_latency_us = -5\n', "supervisor.cpu_latency_us", 2,
     "microseconds >= 0"),
    ('[supervisor]\ncpu_latency_us = 0.5\n', "supervisor.cpu_latency_us", 2, "must be int"),
    ('[supervisor]\ncpu_latency = 0\n', "supervisor.cpu_latency", 2,
     "did you mean 'cpu_latency_us'"),
    ('[supervisor]\non_give_up = "stop_components"\n', "supervisor.on_give_up", 2,
     "did you mean 'stop_component'"),
    ('[supervisor]\non_exceeded = "escalate"\n', "supervisor.on_exceeded", 2,
     "replaced by 'on_give_up'"),
    ('[supervisor]\nprobation = 5\n', "supervisor.probation", 2, "replaced by 'retry_after'"),
    ('[supervisor]\nretry_after = -1\n', "supervisor.retry_after", 2,
     "seconds >= 0 or 'never'"),
    ('[supervisor]\nretry_after = "later"\n', "supervisor.retry_after", 2, "'never'"),
    ('[supervisor]\nshared_intensity = "lots"\n', "supervisor.shared_intensity", 2,
     "must be int"),
    ('[supervisor.groups]\nmission = ["alpah"]\n[components.alpha]\nmodule = "a:B"\n',
     "supervisor.groups.mission", 2, "no component 'alpah'; did you mean 'alpha'"),
    ('[supervisor.groups]\nm = ["a"]\nn = ["a"]\n[components.a]\nmodule = "a:B"\n',
     "supervisor.groups.n", 3, "already in group 'm'"),
    ('[supervisor.groups]\nm = "a"\n[components.a]\nmodule = "a:B"\n',
     "supervisor.groups.m", 2, "non-empty list of component ids"),
    ('[supervisor.groups]\nm = { children = ["a"], intensty = 2 }\n[components.a]\n'
     'module = "a:B"\n', "supervisor.groups.m.intensty", None, "did you mean 'intensity'"),
    ('[supervisor]\nstrategy = "one_for_all"\n[supervisor.groups]\nm = ["a"]\n'
     '[components.a]\nmodule = "a:B"\n', "supervisor", 1, "groups need strategy"),
    ('[components.a]\nmodule = "a:B"\nbackoff = "no"\n', "components.a.backoff", 3,
     "must be bool"),
    ('[components.a]\nrestart = "permanent"\n', "components.a.kind", 1, "required"),
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


def test_unknown_tables_and_near_miss_options_are_kept_for_mrss_check(tmp_path: Path) -> None:
    """Loading is quiet: `mrss check` judges unknown tables and misspelt keys (one place)."""
    cfg = load_file(write(tmp_path, '[robots.uav1]\nlink = "mavlink"\n[supervsior]\nx = 1\n'
                                    '[components.a]\nmodule = "a:B"\nrestarts = 1\n'))
    assert cfg.sections["robots"] == {"uav1": {"link": "mavlink"}}
    assert cfg.sections["supervsior"] == {"x": 1}
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


def test_component_scheduling_is_read_checked_and_applied_to_every_thread(
        tmp_path: Path) -> None:
    cfg = load_file(write(tmp_path, '[components.a]\nmodule = "x.y:Z"\nnice = 5\n'
                                    'cpus = [0, 0]\nrealtime = 10\n'
                                    '[components.b]\nmodule = "x.y:Z"\n'))
    a, b = cfg.child_specs()
    assert (a.start.scheduling.nice, a.start.scheduling.cpus) == (5, (0,))
    assert a.start.scheduling.realtime == 10
    assert (b.start.scheduling.nice, b.start.scheduling.cpus) == (None, None)
    assert "nice" not in cfg.components[0].options  # not a component option
    for bad, key in (("nice = -21", "nice"), ("nice = 1.5", "nice"), ("cpus = []", "cpus"),
                     ("cpus = [-1]", "cpus"), ('cpus = "0"', "cpus"),
                     ("realtime = 0", "realtime"), ("realtime = 100", "realtime")):
        with pytest.raises(ConfigError, match=f"components.a.{key}"):
            load_file(write(tmp_path, f'[components.a]\nmodule = "x.y:Z"\n{bad}\n'))
    # In a real process: the thread that existed before and one started after both run
    # at the nice value, on the given CPU.
    script = """
import logging, os, threading
from mrss.runtime.main import apply_scheduling
before = threading.Event(); done = threading.Event(); seen = {}
def look(name):
    seen[name] = (os.getpriority(os.PRIO_PROCESS, threading.get_native_id()),
                  sorted(os.sched_getaffinity(threading.get_native_id())))
def early():
    before.wait(); look("early"); done.set()
threading.Thread(target=early).start()
apply_scheduling({"nice": 7, "cpus": [0]}, logging.getLogger("t"))
before.set(); done.wait()
later = threading.Thread(target=look, args=("later",)); later.start(); later.join()
look("main")
print(seen)
"""
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                         timeout=30, check=True).stdout
    assert out.strip() == str({"early": (7, [0]), "later": (7, [0]), "main": (7, [0])})
