"""Declaring a robot's failsafe: accepted values, and errors that name the key."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from mrss.check.robots import link_problems
from mrss.errors import ConfigError, DecodeError
from mrss.links.factory import create_link
from mrss.links.failsafe import (
    FailsafeAction,
    FailsafePolicy,
    LinkDownCause,
    failsafe_reason,
    link_down_cause,
    policy_of,
)
from mrss.links.mavlink import MavlinkLink
from mrss.links.mqtt import MqttLink
from mrss.links.ugv_protocol import UgvHeartbeat, parse_heartbeat, parse_telemetry

SOURCE = "projects/x/project.toml"


def test_declared_failsafe_reaches_both_kinds_of_link() -> None:
    uav = create_link("uav1", "mavlink", {"url": "udpin:127.0.0.1:14550", "failsafe": "hold",
                                          "failsafe_timeout": 8})
    ugv = create_link("ugv1", "mqtt", {"broker_url": "mqtt://127.0.0.1:1884",
                                       "failsafe": "RTL"})
    none = create_link("uav2", "mavlink", {"url": "udpin:127.0.0.1:14551"})
    assert isinstance(uav, MavlinkLink) and isinstance(ugv, MqttLink)
    assert uav.failsafe == FailsafePolicy(FailsafeAction.HOLD, 8.0)
    assert ugv.failsafe == FailsafePolicy(FailsafeAction.RTL, 5.0)  # ArduPilot's default
    assert none.failsafe is None  # the robot's own setting is left alone


@pytest.mark.parametrize(("options", "key", "text"), [
    ({"failsafe": "hodl"}, "failsafe", "unknown failsafe 'hodl' (known: hold, rtl, stop); "
                                       "did you mean 'hold'?"),
    ({"failsafe": "land"}, "failsafe", "known: hold, rtl, stop"),
    ({"failsafe": 3}, "failsafe", "must be of type str"),
    ({"failsafe": "stop", "failsafe_timeout": 1}, "failsafe_timeout",
     "must be seconds between 2 and 120, not 1"),
    ({"failsafe": "stop", "failsafe_timeout": "5"}, "failsafe_timeout", "of type float"),
    ({"failsafe_timeout": 5.0}, "failsafe_timeout", "needs failsafe = 'hold' | 'rtl' | 'stop'"),
])
def test_bad_failsafe_settings_are_refused_naming_the_key(
        options: dict[str, object], key: str, text: str) -> None:
    with pytest.raises(ConfigError, match=text.replace("(", r"\(").replace(")", r"\)")
                       .replace("|", r"\|").replace("?", r"\?")) as info:
        create_link("uav1", "mavlink", {"url": "udpin:127.0.0.1:14550", **options},
                    source=SOURCE)
    assert info.value.key == key and info.value.file == SOURCE


def test_mrss_check_reports_a_misspelt_failsafe() -> None:
    problems = link_problems("mqtt", {"link": "mqtt", "failsafe": "stpo"}, set())
    assert problems == [("failsafe", "unknown failsafe 'stpo' (known: hold, rtl, stop); "
                                     "did you mean 'stop'?")]
    assert link_problems("mavlink", {"failsafe": 4}, set()) == [
        ("failsafe", "must be of type str, not 4")]  # one problem per key
    assert link_problems("mavlink", {"failsafe": "rtl", "failsafe_timeout": 30}, set()) == []


def test_table_keys_are_named_with_their_prefix() -> None:
    with pytest.raises(ConfigError) as info:
        policy_of({"failsafe": "hover"}, prefix="components.rcl.robots.uav1.")
    assert info.value.key == "components.rcl.robots.uav1.failsafe"


def test_failsafe_reasons_carry_their_cause() -> None:
    assert link_down_cause(failsafe_reason("uav1 lost its controller")) \
        is LinkDownCause.FAILSAFE
    assert link_down_cause("no heartbeat for 3.0 s") is LinkDownCause.UNREACHABLE


@pytest.mark.parametrize(("args", "text"), [
    (("uav", "--failsafe", "hodl"), "key '--failsafe': unknown failsafe 'hodl'"),
    (("ugv", "--failsafe-timeout", "5"), "key '--failsafe-timeout': needs --failsafe"),
    (("uav", "--failsafe", "rtl", "--failsafe-timeout", "0.5"), "between 2 and 120"),
])
def test_simulator_command_lines_refuse_bad_failsafes(args: tuple[str, ...], text: str) -> None:
    out = subprocess.run([sys.executable, "-m", "mrss", "sim", *args], capture_output=True,
                         text=True, timeout=60)
    assert out.returncode == 2 and text in out.stderr


def test_ugv_protocol_heartbeat_and_telemetry_fields() -> None:
    beat = UgvHeartbeat(1.5e9, FailsafeAction.RTL, 6.0)
    assert parse_heartbeat(beat.to_json()) == beat
    assert parse_heartbeat(b'{"ts": 1.0}') == UgvHeartbeat(1.0)
    for bad in (b'{"ts": 1, "failsafe": "fly"}', b'{"ts": 1, "timeout": 0.1}', b'{}',
                b'[1]', b'{"ts": 1, "failsafe": "hold", "timeout": "5"}'):
        with pytest.raises(DecodeError):
            parse_heartbeat(bad, "mrss/robots/u/heartbeat")
    old = {"id": "u", "ts": 1.0, "lat": 0.0, "lon": 0.0, "heading": 0.0, "speed": 0.0,
           "battery": 50.0, "tank": 1.0, "tank_capacity": 2.0, "pumping": False,
           "mode": "idle", "at_base": True, "teleop": False}
    t = parse_telemetry(json.dumps(old).encode(), "u")  # a robot without a failsafe watch
    assert not t.failsafe and t.controller
    with pytest.raises(DecodeError, match="'failsafe' must be true or false"):
        parse_telemetry(json.dumps({**old, "failsafe": "yes"}).encode(), "u")
