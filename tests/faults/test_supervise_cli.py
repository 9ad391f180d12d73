"""`mrss supervise` as a real process: graceful stop, nothing left behind, giving up."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import psutil
import pytest

from mrss.runtime.forkserver import is_fork_server
from mrss.testing import wait_until

PROJECTS = Path(__file__).resolve().parent.parent / "projects"


def env() -> dict[str, str]:
    return {**os.environ, "MRSS_PROJECTS": str(PROJECTS)}


@pytest.fixture()
def supervise(tmp_path: Path) -> Iterator[list[subprocess.Popen[str]]]:
    procs: list[subprocess.Popen[str]] = []
    try:
        yield procs
    finally:
        for proc in procs:
            if proc.poll() is None:
                for child in psutil.Process(proc.pid).children(recursive=True):
                    child.kill()
                proc.kill()
            proc.communicate(timeout=10)


def start(procs: list[subprocess.Popen[str]], project: str, run_dir: Path,
          *extra: str) -> subprocess.Popen[str]:
    proc = subprocess.Popen(
        [sys.executable, "-m", "mrss", "supervise", project, "--run-dir", str(run_dir), *extra],
        env=env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    procs.append(proc)
    return proc


@pytest.mark.parametrize("launcher", ["fork", "exec"])
def test_graceful_shutdown_leaves_no_process_of_the_tree(
        supervise: list[subprocess.Popen[str]], tmp_path: Path, launcher: str) -> None:
    proc = start(supervise, "demo", tmp_path, "--launcher", launcher)
    wait_until(lambda: all((tmp_path / f"{c}.1.started").exists()
                           for c in ("alpha", "beta", "gamma")), timeout=20,
               message="demo components started")
    # 3 components + beta's helper (+ the fork server)
    expected = 5 if launcher == "fork" else 4
    pids = wait_until(lambda: (lambda found: found if len(found) == expected else None)(
        {p.pid for p in psutil.Process(proc.pid).children(recursive=True)}),
        timeout=20, message=f"{expected} processes in the tree")
    assert not (tmp_path / "off.1.started").exists()
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == 0, err
    left = [p for p in pids if psutil.pid_exists(p)
            and psutil.Process(p).status() != psutil.STATUS_ZOMBIE]
    assert left == []
    order = [line.split(" exit ")[1].split()[0] for line in err.splitlines() if " exit " in line]
    assert order == ["gamma", "beta", "alpha"], err


def test_sigint_stops_the_tree_and_exits_zero(
        supervise: list[subprocess.Popen[str]], tmp_path: Path) -> None:
    proc = start(supervise, "demo", tmp_path)
    wait_until(lambda: (tmp_path / "gamma.1.started").exists(), timeout=20)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == 0, err
    assert "all components stopped" in err


def test_budget_exceeded_with_stop_system_makes_supervise_exit_nonzero_naming_the_child(
        supervise: list[subprocess.Popen[str]], tmp_path: Path) -> None:
    proc = start(supervise, "crashloop", tmp_path)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 1
    last = err.strip().splitlines()[-1]
    assert last == ("mrss supervise: crashloop: gave up: child 'flaky' failed "
                    "(crashed: RuntimeError in start: flaky refuses to start); "
                    "more than 2 restarts of flaky in 30s")
    assert err.count("restart flaky") == 2


def test_a_component_killed_beyond_its_budget_is_stopped_alone_and_the_rest_runs_on(
        supervise: list[subprocess.Popen[str]], tmp_path: Path) -> None:
    log = tmp_path / "stderr.log"
    with log.open("w") as err_file:
        proc = subprocess.Popen(
            [sys.executable, "-m", "mrss", "supervise", "demo", "--run-dir", str(tmp_path)],
            env=env(), stdout=subprocess.DEVNULL, stderr=err_file, text=True)
    supervise.append(proc)
    for inc in range(1, 5):  # intensity 3: the 4th kill is one too many
        marker = tmp_path / f"alpha.{inc}.started"
        wait_until(lambda m=marker: m.exists() and m.read_text(), timeout=20,  # type: ignore[misc]
                   message=f"alpha incarnation {inc}")
        os.kill(int(marker.read_text()), signal.SIGKILL)
    wait_until(lambda: "give_up alpha" in log.read_text(), timeout=20, message="alpha given up")
    line = next(x for x in log.read_text().splitlines() if "give_up alpha" in x)
    assert "reason='killed: SIGKILL'" in line and "stops=component" in line
    assert "note=more than 3 restarts of alpha in 10s" in line and "retry_in=60.0" in line
    assert proc.poll() is None  # the root keeps the others running
    for other in ("beta", "gamma"):
        pid = int((tmp_path / f"{other}.1.started").read_text())
        assert psutil.pid_exists(pid) and psutil.Process(pid).status() != "zombie"
    assert not (tmp_path / "alpha.5.started").exists()
    proc.send_signal(signal.SIGTERM)
    assert proc.wait(timeout=30) == 0
    assert "all components stopped" in log.read_text()


def test_a_killed_fork_server_under_mrss_supervise_restarts_no_component(
        supervise: list[subprocess.Popen[str]], tmp_path: Path) -> None:
    proc = start(supervise, "demo", tmp_path)
    pids = {c: wait_until(lambda c=c: (tmp_path / f"{c}.1.started").exists()  # type: ignore[misc]
                          and (tmp_path / f"{c}.1.started").read_text(), timeout=20)
            for c in ("alpha", "beta", "gamma")}
    (server,) = [p for p in psutil.Process(proc.pid).children()
                 if is_fork_server(p.cmdline(), p.name())]
    server.kill()
    server.wait(timeout=10)

    def new_server() -> list[psutil.Process]:
        return [p for p in psutil.Process(proc.pid).children()
                if is_fork_server(p.cmdline(), p.name()) and p.pid != server.pid]

    (replacement,) = wait_until(new_server, timeout=20, message="a new fork server")
    for pid in pids.values():  # the components live on, unrestarted, adopted by the root
        assert psutil.Process(int(pid)).status() != "zombie"
        assert psutil.Process(int(pid)).name().startswith("mrss:")  # named after theirs
        assert psutil.Process(int(pid)).ppid() == proc.pid  # still in the system's tree
    os.kill(int(pids["alpha"]), signal.SIGKILL)  # a restart now goes through the new one
    wait_until(lambda: (tmp_path / "alpha.2.started").exists()
               and (tmp_path / "alpha.2.started").read_text(), timeout=20, message="alpha 2")
    alpha2 = int((tmp_path / "alpha.2.started").read_text())
    assert psutil.Process(alpha2).ppid() == replacement.pid
    assert not (tmp_path / "beta.2.started").exists()
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == 0, err
    assert "restart forkserver" in err and "kept=3" in err
    assert "exit status unknown" not in err  # the adopted alpha was reaped with its status


def test_bad_config_exits_two_naming_file_and_key(tmp_path: Path) -> None:
    result = subprocess.run([sys.executable, "-m", "mrss", "supervise", "broken"], env=env(),
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 2
    assert "project.toml:7: key 'components.alpha.restart'" in result.stderr


def test_second_signal_kills_a_child_that_is_slow_to_stop(
        supervise: list[subprocess.Popen[str]], tmp_path: Path) -> None:
    (tmp_path / "slowstop").mkdir()
    (tmp_path / "slowstop" / "project.toml").write_text(
        '[components.slow]\nmodule = "tests.projects.workers:Worker"\n'
        'shutdown = 60.0\nstop_delay = 60\n')
    log = tmp_path / "stderr.log"
    with log.open("w") as err_file:
        proc = subprocess.Popen(
            [sys.executable, "-m", "mrss", "supervise", "slowstop", "--run-dir", str(tmp_path)],
            env={**os.environ, "MRSS_PROJECTS": str(tmp_path)}, stdout=subprocess.DEVNULL,
            stderr=err_file, text=True)
    supervise.append(proc)
    wait_until(lambda: "start slow" in log.read_text(), timeout=20)
    proc.send_signal(signal.SIGINT)
    wait_until(lambda: "stopping every child" in log.read_text(), timeout=10)
    proc.send_signal(signal.SIGINT)  # the child takes 60 s to stop: the second one kills it
    assert proc.wait(timeout=20) == 0
    assert "reason='shutdown: killed (forced stop)'" in log.read_text()


@pytest.mark.slow
@pytest.mark.parametrize("launcher", ["fork", "exec"])
def test_components_do_not_outlive_a_killed_root_supervisor(
        supervise: list[subprocess.Popen[str]], tmp_path: Path, launcher: str) -> None:
    proc = start(supervise, "demo", tmp_path, "--launcher", launcher)
    wait_until(lambda: all((tmp_path / f"{c}.1.started").exists()
                           for c in ("alpha", "beta", "gamma")), timeout=20)
    tree = wait_until(lambda: (lambda found: found if len(found) >= 4 else None)(
        psutil.Process(proc.pid).children(recursive=True)),
        timeout=20, message="three components and beta's helper")
    proc.kill()
    proc.wait(timeout=10)
    _, alive = psutil.wait_procs(tree, timeout=10)
    assert alive == []


def _pm_qos_holders(pid: int) -> int:
    """How many of `pid`'s open files are the PM QoS CPU latency file."""
    fds = Path(f"/proc/{pid}/fd")
    return sum(1 for fd in fds.iterdir() if os.path.realpath(fd) == "/dev/cpu_dma_latency")


def test_cpu_latency_us_is_held_by_the_root_supervisor_while_the_system_runs(
        supervise: list[subprocess.Popen[str]], tmp_path: Path) -> None:
    """As root (CI) the root supervisor holds /dev/cpu_dma_latency open with the value
    while it runs; without write access to it the run goes on and says why."""
    projects = tmp_path / "projects"
    (projects / "latency").mkdir(parents=True)
    (projects / "latency" / "project.toml").write_text(
        '[project]\nname = "latency"\n\n[supervisor]\ncpu_latency_us = 0\n\n'
        '[components.alpha]\nmodule = "tests.projects.workers:Worker"\n')
    run_dir = tmp_path / "run"
    run_dir.mkdir()
    proc = subprocess.Popen(
        [sys.executable, "-m", "mrss", "supervise", "latency", "--run-dir", str(run_dir)],
        env={**os.environ, "MRSS_PROJECTS": str(projects)},
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    supervise.append(proc)
    wait_until(lambda: (run_dir / "alpha.1.started").exists(), timeout=20,
               message="alpha started")
    allowed = os.access("/dev/cpu_dma_latency", os.W_OK)
    if allowed:
        assert _pm_qos_holders(proc.pid) == 1
        with open("/dev/cpu_dma_latency", "rb") as current:  # the tightest request held
            assert int.from_bytes(current.read(4), sys.byteorder, signed=True) == 0
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == 0, err
    if allowed:
        assert "CPUs held to wake within 0 us" in err
    else:
        assert "cpu_latency_us 0 not applied: cannot open /dev/cpu_dma_latency" in err
