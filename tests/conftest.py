"""Shared fixtures: a private MQTT broker per test session, a run directory; each
parallel worker's share of ports."""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import pytest_timeout

from mrss import ports
from mrss.testing import (
    BrokerInfo,
    amqtt_broker,
    find_mosquitto,
    mosquitto_broker,
    stretch,
)
from tests import mosquitto

REPO = Path(__file__).resolve().parent.parent


def pytest_configure(config: pytest.Config) -> None:
    """Under pytest-xdist each worker runs its own systems at the same time as the
    others: give each worker (and the processes it starts) ports of its own, so two
    workers never choose the same port in the moment before it is bound."""
    _children_import_the_tests()
    worker = os.environ.get("PYTEST_XDIST_WORKER", "")  # gw0, gw1, ...
    count = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
    if worker.startswith("gw") and count > 1:
        shares = ports.shares(count)
        if shares:
            os.environ[ports.SHARE_VARIABLE] = shares[int(worker[2:])]


@pytest.hookimpl(tryfirst=True)
def pytest_timeout_set_timer(item: pytest.Item, settings: Any) -> object:
    """The hang guard (pytest-timeout, `timeout` in setup.cfg) stretches with the
    machine's load as every wait in the tests does (mrss.testing.stretch, at most 4x):
    a long test through real processes whose waits were each given more time on a
    loaded machine is not cut short by a guard that was not. A hang still ends it."""
    factor = stretch()
    if factor <= 1.0 or not settings.timeout:
        return None  # pytest-timeout's own
    return pytest_timeout.pytest_timeout_set_timer(
        item, settings._replace(timeout=settings.timeout * factor))


def _children_import_the_tests() -> None:
    """The test projects name components in tests/ (`module = "tests.projects.workers:
    Worker"`), but the processes MRSS starts leave the working directory off `sys.path`
    (`python -P`, mrss/interpreter.py): the repository goes on their PYTHONPATH."""
    paths = os.environ.get("PYTHONPATH", "").split(os.pathsep)
    if str(REPO) not in paths:
        os.environ["PYTHONPATH"] = os.pathsep.join([str(REPO), *filter(None, paths)])


def pytest_report_header(config: pytest.Config) -> str:
    binary = find_mosquitto()
    required = f" ({mosquitto.REQUIRE_ENV}=1)" if mosquitto.required() else ""
    return f"mqtt broker for tests: {'mosquitto at ' + binary if binary else 'embedded amqtt'}" \
        + required


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item: pytest.Item, call: pytest.CallInfo[None]
                              ) -> Iterator[None]:
    """Name the MQTT broker a test ran on in its report (shown with a failure, and in
    junit's properties): Mosquitto and amqtt differ where it matters."""
    outcome = yield
    report = outcome.get_result()  # type: ignore[attr-defined]
    broker = getattr(item, "funcargs", {}).get("mqtt_broker")
    if report.when == "call" and isinstance(broker, BrokerInfo):
        report.sections.append(("mqtt broker", f"{broker.kind} on {broker.url}"))
        report.user_properties.append(("mqtt_broker", broker.kind))


@pytest.fixture(scope="session")
def mqtt_broker() -> Iterator[BrokerInfo]:
    """A private broker on a free loopback port: Mosquitto if installed, else amqtt
    (never in place of a required Mosquitto: tests/mosquitto.py)."""
    binary = find_mosquitto()
    if binary is None and mosquitto.required():
        pytest.fail(f"no mosquitto for the mqtt_broker fixture ({mosquitto.REQUIRE_ENV}=1)",
                    pytrace=False)
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
