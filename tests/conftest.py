"""Shared fixtures: a private MQTT broker per test session, a run directory."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from mrss.testing import BrokerInfo, amqtt_broker, find_mosquitto, mosquitto_broker


def pytest_report_header(config: pytest.Config) -> str:
    binary = find_mosquitto()
    return f"mqtt broker for tests: {'mosquitto at ' + binary if binary else 'embedded amqtt'}"


@pytest.fixture(scope="session")
def mqtt_broker() -> Iterator[BrokerInfo]:
    """A private broker on a free loopback port: Mosquitto if installed, else amqtt."""
    binary = find_mosquitto()
    if binary:
        with mosquitto_broker(binary) as info:
            yield info
    else:
        with amqtt_broker() as info:
            yield info


@pytest.fixture()
def amqtt() -> Iterator[BrokerInfo]:
    """The embedded amqtt broker, for tests that must run against it explicitly."""
    with amqtt_broker() as info:
        yield info
