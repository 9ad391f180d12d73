"""Mosquitto for the tests that need it: skipped without it, failed instead on CI.

`MRSS_REQUIRE_MOSQUITTO=1` (set by .ci/run, which installs Mosquitto) turns "no Mosquitto
here" from a skip into a failure, and stops the `mqtt_broker` fixture from standing in
the embedded amqtt broker for it, as `MRSS_REQUIRE_POSTGIS` does for PostGIS.
"""

from __future__ import annotations

import os
import shutil

import pytest

REQUIRE_ENV = "MRSS_REQUIRE_MOSQUITTO"


def required() -> bool:
    """Whether this run must have Mosquitto (CI)."""
    return os.environ.get(REQUIRE_ENV) == "1"


def require_mosquitto(binary: str | None, why: str, tools: tuple[str, ...] = ()) -> str:
    """`binary` (find_mosquitto's answer), with `tools` (other programs) on PATH; else
    skip the test, or fail it when Mosquitto is required."""
    missing = [name for name in tools if shutil.which(name) is None]
    if binary is None:
        missing.insert(0, "mosquitto")
    if missing:
        message = f"{why} needs {', '.join(missing)}"
        if required():
            pytest.fail(f"{message} ({REQUIRE_ENV}=1)", pytrace=False)
        pytest.skip(message)
    assert binary is not None
    return binary
