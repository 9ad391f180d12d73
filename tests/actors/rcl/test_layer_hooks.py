"""What the RCL binds into a project's RobotCommLayer: telemetry, data calls, link states."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import pytest

from mrss.api import RobotCommLayer
from mrss.errors import ActionError
from mrss.messages import Message, RobotData, decode, encode


def test_unbound_layer_degrades_without_raising_on_telemetry() -> None:
    layer = RobotCommLayer()
    assert layer.publish_data("uav1", {"type": "position", "lat": 1.0}) is False
    with pytest.raises(ActionError, match="no data layer"):
        layer.data_call("ground", "a1")
    layer.report_link("uav1", False, "waiting for first heartbeat")  # remembered, no error


def test_bound_layer_publishes_calls_and_replays_link_states() -> None:
    sent: list[Message] = []
    calls: list[tuple[str, list[Any], float | None]] = []
    marks: list[tuple[str, bool, str]] = []

    def data_call(function: str, args: Sequence[Any], timeout: float | None) -> Any:
        calls.append((function, list(args), timeout))
        return {"id": args[0]}

    layer = RobotCommLayer()
    layer.report_link("uav1", False, "no heartbeat for 3.0 s")
    layer.report_link("ugv1", True, "telemetry from ugv1")
    layer.bind_runtime(publish=sent.append, data_call=data_call)
    layer.bind_runtime(link_state=lambda r, up, why: marks.append((r, up, why)))
    assert marks == [("uav1", False, "no heartbeat for 3.0 s"),
                     ("ugv1", True, "telemetry from ugv1")]

    assert layer.publish_data("uav1", {"type": "battery", "remaining": 42})
    assert isinstance(sent[0], RobotData) and sent[0].data["remaining"] == 42
    topic, payload = encode(sent[0], src="rcl")
    assert decode(topic, payload).topic == "robot.uav1.data"

    assert layer.data_call("ground", "a1", timeout=2.0) == {"id": "a1"}
    assert calls == [("ground", ["a1"], 2.0)]

    layer.report_link("uav1", True, "heartbeat resumed from system 1")
    layer.report_link("ugv1", False, "broker connection lost")
    assert marks[-2:] == [("uav1", True, "heartbeat resumed from system 1"),
                          ("ugv1", False, "broker connection lost")]


def test_a_failing_publisher_or_availability_sink_is_contained() -> None:
    def boom(*args: Any) -> None:
        raise RuntimeError("bus gone")

    layer = RobotCommLayer()
    layer.bind_runtime(publish=boom, link_state=boom)
    assert layer.publish_data("uav1", {"type": "text"}) is False
    layer.report_link("uav1", False, "link closed")          # logged, not raised


def test_a_links_samples_are_handed_over_in_the_bound_gathering(tmp_path: Any) -> None:
    """connect_robot gives the links it makes the layer's sample scope; bound to the
    RCL's publisher, the records of one sample leave as one bus message."""
    from collections.abc import Iterator
    from contextlib import contextmanager

    from mrss.testing import free_port

    opened: list[str] = []

    @contextmanager
    def gather() -> Iterator[None]:
        opened.append("gather")
        yield

    layer = RobotCommLayer()
    with layer.sample_scope():  # unbound: nothing special
        pass
    layer.bind_runtime(gather=gather)
    with layer.sample_scope():
        pass
    assert opened == ["gather"]
    link = layer.connect_robot("ugv9", {"link": "mqtt",
                                        "broker_url": f"mqtt://127.0.0.1:{free_port()}"})
    try:
        assert link._sample_scope == layer.sample_scope
    finally:
        layer.disconnect_robot("ugv9", link)
