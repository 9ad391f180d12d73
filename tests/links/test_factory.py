"""Links built from configuration: kinds, option checks, clear errors."""

from __future__ import annotations

import pytest

from mrss.errors import ConfigError
from mrss.links.errors import LinkError
from mrss.links.factory import create_link
from mrss.links.mavlink import MavlinkLink
from mrss.links.mqtt import MqttLink


def test_builds_each_kind_with_its_options() -> None:
    uav = create_link("uav1", "mavlink", {"url": "udpin:127.0.0.1:14550",
                                          "heartbeat_timeout": 5, "retries": 2})
    assert isinstance(uav, MavlinkLink) and uav.heartbeat_timeout == 5.0 and uav.retries == 2
    ugv = create_link("ugv1", "mqtt", {"broker_url": "mqtt://127.0.0.1:1884",
                                       "prefix": "field/robots"})
    assert isinstance(ugv, MqttLink)
    assert ugv.topics.cmd == "field/robots/ugv1/cmd"
    assert not uav.up and not ugv.up and uav.reason == "not connected yet"


@pytest.mark.parametrize("kind, options, message", [
    ("can", {}, "unknown link kind 'can'"),
    ("mavlink", {}, "needs 'url'"),
    ("mavlink", {"url": "udpin:127.0.0.1:1", "speed": 3}, "unknown mavlink link option"),
    ("mavlink", {"url": "udpin:127.0.0.1:1", "retries": "3"}, "'retries' must be of type int"),
    ("mqtt", {"broker_url": "http://x"}, "mqtt://"),
    ("mqtt", {"broker_url": "mqtt://x", "telemetry_timeout": True}, "must be of type float"),
])
def test_bad_configuration_is_a_config_error(kind: str, options: dict[str, object],
                                             message: str) -> None:
    with pytest.raises(ConfigError, match=message) as info:
        create_link("r1", kind, options, source="projects/x/project.toml")
    if "unknown link kind" not in message and "mqtt://" not in message:
        assert "project.toml" in str(info.value)


def test_unopenable_mavlink_address_is_a_link_error() -> None:
    link = create_link("b", "mavlink", {"url": "udpin:nowhere.invalid:1"})
    with pytest.raises(LinkError, match="cannot open udpin:nowhere.invalid:1"):
        link.start()
