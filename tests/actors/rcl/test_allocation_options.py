"""An RCL option of an earlier version that allocation no longer uses (`bid_timeout`):
a project that sets it still starts, and is told, once, to remove it."""

from __future__ import annotations

import logging
from pathlib import Path

import pytest

from mrss.actors.rcl.service import RclService
from mrss.bus import BusEndpoints
from tests.actors.rcl.test_rcl_bus import PROJECT, _ctx, bus  # noqa: F401 (the fixture)


def test_a_project_setting_bid_timeout_starts_with_a_warning(
        bus: tuple[BusEndpoints, Path], caplog: pytest.LogCaptureFixture) -> None:  # noqa: F811
    endpoints, run_dir = bus
    options = {"robots": {"ugv1": {"leg": 0.01}}, "bid_timeout": 2.0}
    ctx = _ctx("rcl", 1, PROJECT, run_dir, endpoints.to_dict(), options)
    service = RclService()
    with caplog.at_level(logging.WARNING, logger="mrss"):
        service.start(ctx)
    try:
        assert service.core is not None and service.core.allocator.profiles.keys() == {"ugv1"}
        said = [r.getMessage() for r in caplog.records if "bid_timeout" in r.getMessage()]
        assert said == ["rcl: bid_timeout is no longer used (an award asks no robot actor "
                        "to confirm its bid); remove it from the project"]
    finally:
        service.stop()
        ctx.publisher.close()
