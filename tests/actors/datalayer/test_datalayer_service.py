"""The data layer service: one reply per request, errors and timeouts as error replies."""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from mrss.actors.datalayer.layer import DataLayer, DataLayerContext
from mrss.actors.datalayer.service import (
    DataLayerService,
    TelemetryQueue,
    load_datalayer_class,
    plain,
    robot_validator,
    world_access,
)
from mrss.actors.worldmodel.local import LocalWorldModel
from mrss.actors.worldmodel.model import WorldModel
from mrss.actors.worldmodel.store import WorldModelStore
from mrss.edge.validation import Rejected
from mrss.errors import ConfigError
from mrss.messages import DataRequest, RobotData
from mrss.runtime.datalayer_client import DataLayerUnavailable
from mrss.world.access import HttpWorldModel
from tests.edge.fixture_project import PROJECT_FIXTURE

# A call's time limit: long where the test is not about it (a loaded machine may take a
# while over any call), short where a call hangs on purpose and must be given up.
PATIENT, HASTY = 30.0, 0.3


@pytest.fixture()
def service() -> Iterator[DataLayerService]:
    yield from _service(PATIENT)


@pytest.fixture()
def hasty_service() -> Iterator[DataLayerService]:
    yield from _service(HASTY)


def _service(call_timeout: float) -> Iterator[DataLayerService]:
    world = WorldModel(WorldModelStore())
    world.seed([{"id": "ugv1", "kind": "robot", "attributes": {"water": 40}},
                {"id": "base1", "kind": "base", "position": {"lat": 43.6, "lon": 1.44}}])
    cls = load_datalayer_class(PROJECT_FIXTURE, {})
    datalayer = cls(DataLayerContext(world=LocalWorldModel(world)))
    svc = DataLayerService(datalayer, call_timeout=call_timeout, workers=2)
    try:
        yield svc
    finally:
        datalayer.stop()
        svc.close()


def ask(svc: DataLayerService, function: str, *args: object) -> tuple[bool, object, str]:
    reply = svc.handle(DataRequest(request_id=f"id-{function}", function=function,
                                   args=list(args)))
    assert reply.request_id == f"id-{function}"
    return reply.ok, reply.result, reply.error


def test_builtin_and_project_functions_answer(service: DataLayerService) -> None:
    assert ask(service, "ping") == (True, "pong", "")
    assert ask(service, "add", 2, 3.5) == (True, 5.5, "")
    ok, result, _ = ask(service, "ground", "base1")
    assert ok and isinstance(result, dict) and result["position"]["lat"] == 43.6
    assert ask(service, "water_left", "ugv1") == (True, 40, "")
    ok, result, _ = ask(service, "objects", "robot")
    assert ok and [o["id"] for o in result] == ["ugv1"]  # type: ignore[attr-defined]
    ok, result, _ = ask(service, "near", 43.6, 1.44, 10.0)
    assert ok and [o["id"] for o in result] == ["base1"]  # type: ignore[attr-defined]


@pytest.mark.parametrize(("function", "args", "reason"), [
    ("fly_to_moon", [], "unknown function 'fly_to_moon'; known: add, explode"),
    ("ground", ["nobody"], "no object 'nobody'"),
    ("ground", [7], "must be a string"),
    ("explode", [], "RuntimeError: the external service is down"),
    ("not_plain", [], "not plain data"),
    ("add", [1], "TypeError"),
])
def test_failures_become_error_replies(service: DataLayerService, function: str,
                                       args: list[object], reason: str) -> None:
    ok, result, error = ask(service, function, *args)
    assert not ok and result is None
    assert reason in error


def test_a_call_past_its_time_limit_becomes_an_error_reply(
        hasty_service: DataLayerService) -> None:
    assert ask(hasty_service, "hang") == (False, None, "hang timed out after 0.3s")


def test_timeouts_do_not_block_later_requests(hasty_service: DataLayerService) -> None:
    service = hasty_service
    assert not ask(service, "hang")[0]
    assert not ask(service, "hang")[0]  # both workers now stuck in hang
    assert service.timeouts == 2
    service.datalayer.stop()  # the fixture releases its hung calls on stop
    assert ask(service, "add", 1, 1) == (True, 2, "")


def test_telemetry_updates_the_robot_in_the_world_model(service: DataLayerService) -> None:
    assert service.telemetry(RobotData(robot="uav1", data={"lat": 43.61, "lon": 1.45,
                                                           "alt": 30, "battery": 77}))
    ok, result, _ = ask(service, "ground", "uav1")
    assert ok and isinstance(result, dict)
    assert result["kind"] == "robot" and result["position"]["alt"] == 30
    assert result["attributes"] == {"battery": 77}
    assert not service.telemetry(RobotData(robot="uav1", data={"lat": 95, "lon": 0}))
    assert service.telemetry_errors == 0  # refused by validation, never handed on
    assert service.rejections.stats() == {"uav1: record.lat out of range": 1}


def test_telemetry_while_the_world_model_is_down_is_one_warning_not_tracebacks(
        caplog: pytest.LogCaptureFixture) -> None:
    class Flaky(DataLayer):
        down = True

        def on_telemetry(self, robot: str, data: Any) -> None:
            if self.down:
                raise DataLayerUnavailable("wm.upsert", "WorldStoreUnavailable: db down")
            super().on_telemetry(robot, data)

    world = WorldModel(WorldModelStore())
    datalayer = Flaky(DataLayerContext(world=LocalWorldModel(world)))
    svc = DataLayerService(datalayer, call_timeout=1)
    record = RobotData(robot="uav1", data={"lat": 43.61, "lon": 1.45})
    try:
        with caplog.at_level(logging.WARNING, logger="mrss.datalayer"):
            assert not svc.telemetry(record) and not svc.telemetry(record)
            datalayer.down = False
            assert svc.telemetry(record)
    finally:
        svc.close()
    assert svc.telemetry_errors == 2 and world.get("uav1") is not None
    messages = [r.getMessage() for r in caplog.records]
    assert len(messages) == 2 and "db down" in messages[0], messages
    assert messages[1] == "telemetry stored again"
    assert not any(r.exc_info for r in caplog.records)


def test_default_datalayer_without_world_model_reports_it() -> None:
    svc = DataLayerService(DataLayer(DataLayerContext(world=None)), call_timeout=1)
    try:
        ok, _, error = ask(svc, "ground", "x")
        assert not ok and "no world model is configured" in error
        assert svc.telemetry(RobotData(robot="r", data={"lat": 1, "lon": 2}))
    finally:
        svc.close()


def test_plain_converts_tuples_and_refuses_objects() -> None:
    assert plain({"a": (1, [2.5, None])}) == {"a": [1, [2.5, None]]}
    for bad in (object(), {1: "x"}, float("nan"), {"s": {1, 2}}):
        with pytest.raises(TypeError):
            plain(bad)


def test_world_model_option() -> None:
    assert world_access({"world_model": "none"}, None) is None
    assert isinstance(world_access({"world_model": "http://127.0.0.1:9"}, None), HttpWorldModel)
    with pytest.raises(ConfigError, match="needs the bus"):
        world_access({}, None)
    with pytest.raises(ConfigError, match="datalayer.world_model"):
        world_access({"world_model": "ftp://x"}, None)


PROJECT_WITH_ROBOTS = """\
[components.rcl]
kind = "rcl"
[components.rcl.robots.uav1]
link = "mavlink"
[components.rcl.robots.ugv1]
link = "mqtt"
"""


def test_robot_data_is_taken_only_from_configured_robots_within_their_limits(
        tmp_path: Path) -> None:
    folder = tmp_path
    (folder / "project.toml").write_text(PROJECT_WITH_ROBOTS)
    validator = robot_validator(folder, {"temperature_range": [-50, 900]})
    assert validator.robots == {"uav1", "ugv1"}
    climb = {"type": "position", "lat": 1, "lon": 2, "alt": 11_000}
    assert validator.check("uav1", climb) == climb  # aerial: up to 12 km
    with pytest.raises(Rejected, match="position.alt out of range"):
        validator.check("ugv1", climb)  # ground: 9 km at most
    with pytest.raises(Rejected, match="hotspot.temperature out of range"):  # overridden
        validator.check("uav1", {"type": "hotspot", "id": 1, "lat": 0, "lon": 0,
                                 "temperature": 1000})
    with pytest.raises(Rejected, match="unknown robot"):
        validator.check("fz9", {"type": "battery", "remaining": 50})
    only = robot_validator(folder, {"robots": ["ugv1"]})
    with pytest.raises(Rejected, match="unknown robot"):
        only.check("uav1", {"type": "battery", "remaining": 50})
    with pytest.raises(ConfigError, match="low <= high"):
        robot_validator(folder, {"alt_range": [10, -10]})


def test_refused_robot_data_never_reaches_the_project(service: DataLayerService) -> None:
    seen: list[tuple[str, object]] = []
    service.datalayer.on_telemetry = lambda robot, data: seen.append((robot, data))  # type: ignore[method-assign]
    for data in ({"type": "hotspot", "id": 9, "lat": 0, "lon": 0, "temperature": 1e308},
                 {"type": "battery", "remaining": -128.0}, {"type": "x", "v": [[[]]] * 300}):
        assert not service.telemetry(RobotData(robot="uav1", data=data))
    assert not seen and service.rejections.total == 3
    assert service.telemetry(RobotData(robot="uav1", data={"type": "battery", "remaining": 50}))
    assert seen == [("uav1", {"type": "battery", "remaining": 50})]


def test_the_telemetry_queue_hands_records_on_in_order_and_outlives_a_failure(
        caplog: pytest.LogCaptureFixture) -> None:
    seen: list[int] = []
    done = threading.Event()
    total = 3000

    def handle(data: RobotData) -> None:
        n = int(data.data["n"])  # type: ignore[arg-type]
        if n == 5:
            raise RuntimeError("a bad record")
        seen.append(n)
        if n == total - 1:
            done.set()

    queue = TelemetryQueue(handle)
    for n in range(total):
        queue.put(RobotData(robot="ugv1", data={"n": n}))
        if n % 500 == 0:  # let the queue run dry so that its thread waits, then wake it
            deadline = time.monotonic() + 5
            while queue.pending() and time.monotonic() < deadline:
                time.sleep(0.001)
    assert done.wait(5.0)
    assert seen == [n for n in range(total) if n != 5]
    assert "telemetry of robot ugv1 was not handled" in caplog.text
    queue.close()
    queue._thread.join(5.0)
    assert not queue._thread.is_alive()
