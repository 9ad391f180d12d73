"""The component runtime on its own: standalone runs, bad targets, the context."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from mrss.errors import BusError, SupervisionError
from mrss.runtime.component import ComponentContext
from mrss.runtime.main import load_class
from mrss.supervision import control
from mrss.testing import wait_until
from tests.projects.workers import Worker


def main_cmd(target: str, tmp_path: Path, *extra: str) -> list[str]:
    ctx = json.dumps({"project_dir": str(tmp_path), "run_dir": str(tmp_path),
                      "options": {}, "heartbeat_interval": 0.05})
    return [sys.executable, "-m", "mrss.runtime.main", target, "--name", "w",
            "--inc", "4", "--context", ctx, *extra]


def test_standalone_component_starts_and_stops_cleanly_on_sigterm(tmp_path: Path) -> None:
    proc = subprocess.Popen(main_cmd("tests.projects.workers:Worker", tmp_path),
                            stderr=subprocess.PIPE, text=True)
    try:
        wait_until((tmp_path / "w.4.started").exists, timeout=20)
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=20) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
        proc.communicate()


def test_control_channel_reports_ready_heartbeats_and_answers_pings(tmp_path: Path) -> None:
    ours, theirs = control.socket_pair()
    cmd = main_cmd("tests.projects.workers:Worker", tmp_path, "--control-fd",
                   str(theirs.fileno()))
    proc = subprocess.Popen(cmd, pass_fds=(theirs.fileno(),))
    theirs.close()
    try:
        ours.settimeout(20)
        assert control.decode(ours.recv(control.MAX_PACKET)) == ("ready", "")
        assert control.decode(ours.recv(control.MAX_PACKET)) == ("hb", "")
        control.send(ours, control.PING, "42")
        deadline = time.monotonic() + 5
        while time.monotonic() < deadline:
            kind, text = control.decode(ours.recv(control.MAX_PACKET))
            if kind == "pong":
                assert text == "42"
                break
        else:
            pytest.fail("no pong")
        ours.close()  # the supervisor is gone: the component must not outlive it
        assert proc.wait(timeout=20) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


@pytest.mark.parametrize(("target", "message"), [
    ("nocolon", "is not 'module.path:Class'"),
    ("tests.projects.nothere:X", "cannot import"),
    ("tests.projects.workers:NotAComponent", "not a subclass"),
])
def test_bad_targets_fail_with_a_clear_error(tmp_path: Path, target: str, message: str) -> None:
    with pytest.raises(SupervisionError, match=message):
        load_class(target)
    result = subprocess.run(main_cmd(target, tmp_path), capture_output=True, text=True,
                            timeout=60)
    assert result.returncode == 1
    assert message in result.stderr


def test_context_round_trips_through_json(tmp_path: Path) -> None:
    ctx = ComponentContext("rcl", 3, tmp_path, tmp_path / "run", bus={"pub": "ipc://x"},
                           options={"a": [1, 2]}, heartbeat_interval=0.2)
    back = ComponentContext.from_json("rcl", 3, ctx.to_json())
    assert (back.project_dir, back.run_dir, back.bus, back.options, back.heartbeat_interval) \
        == (tmp_path, tmp_path / "run", {"pub": "ipc://x"}, {"a": [1, 2]}, 0.2)
    with pytest.raises(SupervisionError, match="bad --context"):
        ComponentContext.from_json("rcl", 3, "{not json")


def test_publisher_without_bus_endpoints_is_a_bus_error(tmp_path: Path) -> None:
    ctx = ComponentContext("rcl", 1, tmp_path, tmp_path)
    with pytest.raises(BusError, match="no bus endpoints"):
        _ = ctx.publisher


def test_worker_is_a_component() -> None:
    assert load_class("tests.projects.workers:Worker") is Worker
