"""`mrss send`: one message per run onto a live bus, validated before anything is sent."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import pytest

from mrss.bus import BusEndpoints, ProxyThread, Subscriber
from mrss.cli import main
from mrss.messages import ActionControl, ActionStatus, Command, Percept
from tests.commands.cli_bus import Bus, mrss, mrss_process, running_bus, short_dir


@pytest.fixture()
def bus() -> Iterator[Bus]:
    with running_bus() as live:
        yield live


def send(bus: Bus, *args: str) -> str:
    """`mrss send --run-dir DIR ARGS`, which must succeed; its stdout."""
    out = mrss("send", "--run-dir", str(bus.run_dir), *args)
    assert out.returncode == 0, out.stderr
    return out.stdout


def test_percept_arrives_on_the_percept_topic(bus: Bus) -> None:
    stdout = send(bus, "percept", "area_goal_received(g1, 3)")
    env = bus.next()
    assert env.body == Percept(literal="area_goal_received(g1, 3)", op="add")
    assert env.topic == "percept"
    assert env.src == "mrss-send"
    assert f"(id {env.id})" in stdout


def test_percept_remove_with_options_after_the_kind(bus: Bus) -> None:
    out = mrss("send", "percept", " fire(a). ", "--remove", "--run-dir", str(bus.run_dir))
    assert out.returncode == 0, out.stderr
    assert bus.next().body == Percept(literal="fire(a)", op="remove")


def test_bad_literal_exits_2_with_a_caret_and_sends_nothing(bus: Bus) -> None:
    out = mrss("send", "--run-dir", str(bus.run_dir), "percept", "area_goal_received(g1, 3")
    assert out.returncode == 2
    lines = out.stderr.splitlines()
    assert lines[0].startswith("mrss send: bad literal: col 25: unexpected end of literal")
    assert lines[1].strip() == "area_goal_received(g1, 3"
    assert lines[2].index("^") == lines[1].index("area") + 24
    assert "<term>" not in out.stderr and "sent" not in out.stdout
    send(bus, "percept", "after_the_bad_one")
    assert bus.next().body == Percept(literal="after_the_bad_one")  # the bad one never came


@pytest.mark.parametrize("literal, reason", [
    ("fire(X)", "has variables"),
    ("fire(a) b", "col 9: unexpected 'b'"),
    ("+!g <- true", "bad literal"),
    ("   ", "empty"),
])
def test_literals_that_are_not_ground_literals_are_refused(
        literal: str, reason: str, capsys: pytest.CaptureFixture[str]) -> None:
    with short_dir() as run_dir:
        assert main(["send", "--run-dir", str(run_dir), "percept", literal]) == 2
    assert reason in capsys.readouterr().err


@pytest.mark.parametrize("command", ["cancel", "suspend", "resume", "succeed", "fail"])
def test_control_commands_reach_action_control(bus: Bus, command: str) -> None:
    send(bus, "control", command, "a1b2")
    env = bus.next()
    assert env.body == ActionControl(command=command, target="a1b2", target_kind="action")
    assert env.topic == "action.control"


def test_control_of_a_goal(bus: Bus) -> None:
    send(bus, "control", "suspend", "g1", "--kind", "goal")
    assert bus.next().body == ActionControl(command="suspend", target="g1", target_kind="goal")


def test_teleop_on_and_off_are_teleop_commands(bus: Bus) -> None:
    send(bus, "teleop", "ugv1", "on")
    send(bus, "teleop", "ugv1", "off")
    first, second = bus.next(), bus.next()
    assert first.topic == second.topic == "ctl.teleop"
    assert first.body == Command(command="teleop", target="ugv1", args={"on": True})
    assert second.body == Command(command="teleop", target="ugv1", args={"on": False})


def test_command_with_target_and_json_or_text_args(bus: Bus) -> None:
    send(bus, "command", "fault", "--target", "rcl", "--arg", "kind=kill",
         "--arg", "after=0.5", "--arg", 'robots=["uav1", 2]', "--arg", "on=true")
    env = bus.next()
    assert env.topic == "ctl.fault"
    assert env.body == Command(command="fault", target="rcl",
                               args={"kind": "kill", "after": 0.5, "robots": ["uav1", 2],
                                     "on": True})


def test_raw_message_of_any_kind(bus: Bus) -> None:
    fields = {"uuid": "a1", "state": "running", "progress": {"pct": 40}}
    send(bus, "raw", "action.status", json.dumps(fields))
    env = bus.next()
    assert env.topic == "action.status"
    assert env.body == ActionStatus(uuid="a1", state="running", progress={"pct": 40})


@pytest.mark.parametrize("kind, text, reason", [
    ("action.status", '{"uuid": "a1"}', "missing field 'state'"),
    ("action.status", '{"uuid": "a1", "state": "dancing"}', "unknown action state 'dancing'"),
    ("action.status", '{"uuid": "a1", "state": 3}', "field 'state' has type int"),
    ("percept", '{"literal": "x", "colour": 1}', "unknown field(s) ['colour']"),
    ("percept", '["x"]', "JSON must be an object"),
    ("percept", "{literal: x}", "JSON is not valid"),
    ("no.such.kind", "{}", "unknown message kind 'no.such.kind'"),
])
def test_raw_validation_errors_exit_2_with_the_reason(
        kind: str, text: str, reason: str, capsys: pytest.CaptureFixture[str]) -> None:
    with short_dir() as run_dir:
        assert main(["send", "--run-dir", str(run_dir), "raw", kind, text]) == 2
    assert reason in capsys.readouterr().err


def test_sub_topic_and_a_topic_that_is_not_the_kinds(bus: Bus) -> None:
    send(bus, "--topic", "percept.uav1", "percept", "hot(a)")
    env = bus.next()
    assert (env.topic, env.body) == ("percept.uav1", Percept(literal="hot(a)"))
    out = mrss("send", "--run-dir", str(bus.run_dir), "--topic", "robot.x", "percept", "hot(a)")
    assert out.returncode == 2
    assert "must be 'percept' or percept.SUB" in out.stderr


def test_tcp_endpoints_instead_of_a_run_dir() -> None:
    endpoints = BusEndpoints.tcp_loopback()
    with ProxyThread(endpoints), Subscriber(endpoints) as sub:
        assert sub.wait_connected(10)
        out = mrss("send", "--endpoints", f"{endpoints.frontend},{endpoints.backend}",
                   "percept", "over_tcp")
        assert out.returncode == 0, out.stderr
        env = sub.recv(timeout=10)
        assert env is not None and env.body == Percept(literal="over_tcp")


def test_run_dir_without_a_bus_exits_2_after_the_timeout() -> None:
    with short_dir() as run_dir:
        out = mrss("send", "--run-dir", str(run_dir), "--timeout", "0.3", "percept", "x")
    assert out.returncode == 2
    assert f"no bus: {run_dir / 'bus-pub.sock'} does not exist (waited 0.3 s" in out.stderr


@pytest.mark.parametrize("where, reason", [
    ([], "give the bus as --run-dir DIR or as --endpoints FRONT,BACK"),
    (["--run-dir", "/nonexistent/mrss-run"], "'/nonexistent/mrss-run' does not exist"),
    (["--endpoints", "tcp://127.0.0.1:1"], "needs FRONT,BACK"),
    (["--endpoints", "udp://x,tcp://127.0.0.1:2"], "--endpoints"),
    (["--run-dir", "/tmp", "--endpoints", "a,b"], "one of them"),
])
def test_bad_bus_options_exit_2(where: list[str], reason: str,
                                capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["send", *where, "percept", "x"]) == 2
    assert reason in capsys.readouterr().err


def test_send_waits_for_a_proxy_that_starts_late() -> None:
    with short_dir() as run_dir:
        endpoints = BusEndpoints.ipc(run_dir)
        with mrss_process("send", "--run-dir", str(run_dir), "--timeout", "30",
                          "percept", "late(proxy)") as cli:
            assert not Path(endpoints.frontend[len("ipc://"):]).exists()
            with ProxyThread(endpoints):
                assert cli.finish() == 0, cli.stderr()
    assert cli.lines[0].startswith("sent percept on percept (id ")
