"""Robots connect without project code: `link = ...` in a robot's table, addresses resolved."""

from __future__ import annotations

import secrets
from pathlib import Path
from typing import Any, ClassVar

import pytest

from mrss.api import ConfigError, RobotCommLayer
from mrss.config.detours import via_file
from mrss.edge.record_declarations import DEFAULT_LIMITS, RobotType
from mrss.links.connect import connect_link, link_options, project_broker_url
from mrss.messages import Message, RobotData
from mrss.testing import BrokerInfo, free_udp_port, wait_until

from .conftest import Spawn

BASE = (-35.3635, 149.1650)


def test_mavlink_without_url_uses_the_address_the_simulator_wrote(tmp_path: Path) -> None:
    (tmp_path / "uav1.mavlink").write_text("udpout:127.0.0.1:14999\n", encoding="utf-8")
    kind, opts = link_options("uav1", {"link": "mavlink", "altitude": 30.0, "failsafe": "hold"},
                              project_dir=None, run_dir=tmp_path, layer_keys=("altitude",))
    assert kind == "mavlink"
    assert opts == {"url": "udpout:127.0.0.1:14999", "failsafe": "hold"}
    kind, opts = link_options("uav1", {"link": "mavlink", "url": "udpin:0.0.0.0:14550"},
                              project_dir=None, run_dir=tmp_path)
    assert opts == {"url": "udpin:0.0.0.0:14550"}   # a real vehicle's url wins


def test_mavlink_without_url_or_simulator_says_what_to_do(tmp_path: Path) -> None:
    with pytest.raises(ConfigError) as info:
        link_options("uav2", {"link": "mavlink"}, project_dir=None, run_dir=tmp_path)
    assert info.value.key == "robots.uav2.url"
    assert "uav2.mavlink" in str(info.value) and "id = 'uav2'" in str(info.value)


def test_mqtt_without_broker_url_uses_the_project_broker(tmp_path: Path) -> None:
    project, run = tmp_path / "proj", tmp_path / "run"
    project.mkdir()
    run.mkdir()
    with pytest.raises(ConfigError) as info:
        link_options("ugv1", {"link": "mqtt"}, project_dir=project, run_dir=run)
    assert info.value.key == "robots.ugv1.broker_url"
    (run / "broker.url").write_text("mqtt://127.0.0.1:1884\n", encoding="utf-8")
    assert link_options("ugv1", {"link": "mqtt"}, project_dir=project, run_dir=run)[1] == \
        {"broker_url": "mqtt://127.0.0.1:1884"}           # the embedded broker's
    (project / "project.toml").write_text('[broker]\nurl = "mqtt://10.0.0.5:1883"\n',
                                          encoding="utf-8")
    assert link_options("ugv1", {"link": "mqtt"}, project_dir=project, run_dir=run)[1] == \
        {"broker_url": "mqtt://10.0.0.5:1883"}            # a configured broker wins


def test_a_table_without_link_has_none_and_bad_options_are_named(tmp_path: Path) -> None:
    assert connect_link("r1", {"speed": 2.0}, project_dir=None, run_dir=tmp_path,
                        layer_keys=("speed",)) is None
    with pytest.raises(ConfigError) as info:
        connect_link("r1", {"link": "mqtt", "broker_url": "mqtt://127.0.0.1:1", "sped": 2.0},
                     project_dir=None, run_dir=tmp_path)
    assert info.value.key == "sped"
    with pytest.raises(ConfigError) as info:
        connect_link("r1", {"link": "can"}, project_dir=None, run_dir=tmp_path)
    assert "unknown link kind 'can'" in str(info.value)
    with pytest.raises(ConfigError, match="http link needs 'url'"):
        connect_link("r1", {"link": "http"}, project_dir=None, run_dir=tmp_path)
    with pytest.raises(ConfigError, match="failsafe"):
        connect_link("r1", {"link": "mqtt", "broker_url": "mqtt://127.0.0.1:1",
                            "failsafe": "hovr"}, project_dir=None, run_dir=tmp_path)


class Layer(RobotCommLayer):
    robot_settings: ClassVar[tuple[str, ...]] = ("litres_per_second",)


def test_default_connect_robot_forwards_telemetry_and_link_state(
        tmp_path: Path, spawn: Spawn, mqtt_broker: BrokerInfo) -> None:
    robot = "ugvconnect"
    run = tmp_path / "run"
    run.mkdir()
    (run / "broker.url").write_text(mqtt_broker.url + "\n", encoding="utf-8")
    spawn("mrss", "sim", "ugv", "--broker", mqtt_broker.url, "--id", robot, "--speedup", "20",
          "--rate", "5", f"--base={BASE[0]},{BASE[1]}")
    sent: list[Message] = []
    states: list[tuple[str, bool, str]] = []
    layer = Layer()
    layer.bind_runtime(project_dir=tmp_path, run_dir=run, publish=sent.append,
                       link_state=lambda r, up, why: states.append((r, up, why)))
    link: Any = layer.connect_robot(robot, {"link": "mqtt", "litres_per_second": 5.0,
                                            "failsafe": "stop", "failsafe_timeout": 5.0})
    try:
        wait_until(lambda: any(r == robot and up for r, up, _ in states), 20, message="link up")
        wait_until(lambda: any(isinstance(m, RobotData) and m.robot == robot for m in sent), 20,
                   message="telemetry forwarded to the data layer")
        assert link.failsafe is not None and link.failsafe.action.value == "stop"
        assert link.failsafe.timeout_s == 5.0
    finally:
        layer.disconnect_robot(robot, link)


def test_default_connect_robot_signs_with_the_projects_key_file(tmp_path: Path,
                                                                spawn: Spawn) -> None:
    (tmp_path / "keys").mkdir()
    (tmp_path / "keys" / "uav1.key").write_text(secrets.token_hex(32) + "\n")
    run = tmp_path / "run"
    run.mkdir()
    port = free_udp_port()
    (run / "uav1.mavlink").write_text(f"udpin:127.0.0.1:{port}\n")  # as the sim component
    spawn("mrss", "sim", "uav", "--out", f"udpout:127.0.0.1:{port}",
          f"--signing-key={tmp_path / 'keys' / 'uav1.key'}")
    states: list[tuple[str, bool, str]] = []
    layer = Layer()
    layer.bind_runtime(project_dir=tmp_path, run_dir=run, publish=lambda _m: None,
                       link_state=lambda r, up, why: states.append((r, up, why)))
    link: Any = layer.connect_robot("uav1", {"link": "mavlink",
                                             "signing_key": "keys/uav1.key"})
    try:
        wait_until(lambda: any(up for _, up, _ in states), 20, message="signed link up")
        assert link.signed and link.refused()["bad signature"] == 0
    finally:
        layer.disconnect_robot("uav1", link)


def test_a_link_applies_the_projects_limits_over_its_robot_types(tmp_path: Path) -> None:
    (tmp_path / "project.toml").write_text('[datalayer]\nalt_range = [-10, 30000]\n')
    link = connect_link("r1", {"link": "http", "url": "http://127.0.0.1:1"},
                        project_dir=tmp_path, run_dir=tmp_path)
    assert link is not None
    try:
        assert (link.limits.alt.low, link.limits.alt.high) == (-10.0, 30_000.0)
        assert link.limits.speed == DEFAULT_LIMITS[RobotType.GROUND].speed  # the rest stays
    finally:
        link.close()


def test_a_campaigns_via_file_detours_the_found_addresses_not_configured_ones(
        tmp_path: Path) -> None:
    (tmp_path / "uav1.mavlink").write_text("udpout:127.0.0.1:5760\n", encoding="utf-8")
    (tmp_path / "broker.url").write_text("mqtt://127.0.0.1:1883\n", encoding="utf-8")
    via_file(tmp_path, "uav1", "mavlink").write_text("127.0.0.1:9001\n", encoding="utf-8")
    via_file(tmp_path, "ugv1", "mqtt").write_text("127.0.0.1:9002\n", encoding="utf-8")
    _, found = link_options("uav1", {"link": "mavlink"}, project_dir=None, run_dir=tmp_path)
    assert found["url"] == "udpout:127.0.0.1:9001"
    _, given = link_options("uav1", {"link": "mavlink", "url": "udpin:0.0.0.0:14550"},
                            project_dir=None, run_dir=tmp_path)
    assert given["url"] == "udpin:0.0.0.0:14550"
    assert project_broker_url(None, tmp_path, "ugv1") == "mqtt://127.0.0.1:9002"
    assert project_broker_url(None, tmp_path) == "mqtt://127.0.0.1:1883"  # the RCL's own
    assert project_broker_url(None, tmp_path, "ugv2") == "mqtt://127.0.0.1:1883"
