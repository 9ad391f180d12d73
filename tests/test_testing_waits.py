"""The test helpers' waits are failure detectors: patient in proportion to the load."""

from __future__ import annotations

import os
import time

import pytest

from mrss import testing
from mrss.testing import MAX_STRETCH, WaitTimeout, stretch, wait_until


def _load(monkeypatch: pytest.MonkeyPatch, per_cpu: float) -> None:
    cpus = os.cpu_count() or 1
    monkeypatch.setattr(testing.os, "getloadavg", lambda: (per_cpu * cpus, 0.0, 0.0))


def test_a_quiet_machine_gets_the_timeout_and_a_loaded_one_more_up_to_the_cap(
        monkeypatch: pytest.MonkeyPatch) -> None:
    _load(monkeypatch, 0.3)
    assert stretch() == 1.0
    _load(monkeypatch, 2.5)
    assert stretch() == 2.5
    _load(monkeypatch, 40.0)
    assert stretch() == MAX_STRETCH


def test_a_wait_on_a_loaded_machine_goes_on_past_its_timeout_and_says_so(
        monkeypatch: pytest.MonkeyPatch) -> None:
    _load(monkeypatch, 3.0)
    started = time.monotonic()
    with pytest.raises(WaitTimeout, match=r"never did not hold within 0\.1s \(waited"):
        wait_until(lambda: False, timeout=0.1, message="never")
    assert time.monotonic() - started >= 0.3  # three times the timeout, at load 3 per CPU


def test_a_condition_that_holds_late_on_a_loaded_machine_is_still_seen(
        monkeypatch: pytest.MonkeyPatch) -> None:
    _load(monkeypatch, 4.0)
    ready_at = time.monotonic() + 0.2
    assert wait_until(lambda: time.monotonic() >= ready_at, timeout=0.1, message="late")
