"""MAV_RESULT_IN_PROGRESS has a budget: a vehicle (or a forger) that answers a command
with IN_PROGRESS for ever cannot hold the link's one command slot for ever, and one that
finishes within the budget is waited for."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from typing import Any

import pytest

from mrss.links.errors import CommandTimeout
from mrss.links.factory import create_link
from mrss.links.mavconn import MAV, MavConnection
from mrss.links.mavlink import MavlinkLink
from mrss.testing import free_udp_port


class ProgressVehicle:
    """Answers each COMMAND_LONG with IN_PROGRESS every 50 ms, `then` (a MAV_RESULT)
    after `progress` acks, or for ever when `then` is None."""

    def __init__(self, port: int, progress: int, then: int | None) -> None:
        self.conn = MavConnection(f"udpout:127.0.0.1:{port}", source_system=7,
                                  source_component=1)
        self.progress, self.then = progress, then
        self.commands: list[Any] = []
        self.acks_sent = 0
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self.run, daemon=True)
        self.thread.start()

    def run(self) -> None:
        mav = self.conn.conn.mav
        answering: int | None = None
        sent = 0
        while not self.stop.is_set():
            self.conn.send(mav.heartbeat_encode(MAV.MAV_TYPE_QUADROTOR,
                                                MAV.MAV_AUTOPILOT_ARDUPILOTMEGA,
                                                MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 4, 3))
            msg = self.conn.recv(timeout=0.05)
            if msg is not None and msg.get_type() == "COMMAND_LONG":
                self.commands.append(msg)
                answering, sent = msg.command, 0
            if answering is None:
                continue
            self.acks_sent += 1  # counted before it is sent: the link may return at once
            if self.then is not None and sent >= self.progress:
                self.conn.send(mav.command_ack_encode(answering, self.then))
                answering = None
            else:
                self.conn.send(mav.command_ack_encode(answering, MAV.MAV_RESULT_IN_PROGRESS))
                sent += 1

    def close(self) -> None:
        self.stop.set()
        self.thread.join(timeout=5)
        self.conn.close()


@pytest.fixture()
def vehicle_link(request: pytest.FixtureRequest) -> Iterator[tuple[MavlinkLink,
                                                                     ProgressVehicle]]:
    progress, then, options = request.param
    port = free_udp_port()
    link = create_link("uav7", "mavlink", {"url": f"udpin:127.0.0.1:{port}", **options})
    assert isinstance(link, MavlinkLink)
    link.start()
    vehicle = ProgressVehicle(port, progress, then)
    try:
        link.wait_up(timeout=10)
        yield link, vehicle
    finally:
        vehicle.close()
        link.close()


@pytest.mark.parametrize("vehicle_link", [
    (0, None, {"command_timeout": 5.0, "retries": 3, "progress_timeout": 0.5})],
    indirect=True)
def test_a_command_in_progress_for_ever_times_out_at_its_budget_and_is_not_resent(
        vehicle_link: tuple[MavlinkLink, ProgressVehicle]) -> None:
    link, vehicle = vehicle_link
    with pytest.raises(CommandTimeout, match="still in progress"):
        link.arm()
    assert vehicle.acks_sent >= 2  # it did say IN_PROGRESS, more than once
    # in progress is an answer: the command is not sent again (the command timeout,
    # 5 s between IN_PROGRESS acks sent every 50 ms, never ran out)
    assert [m.command for m in vehicle.commands] == [MAV.MAV_CMD_COMPONENT_ARM_DISARM]
    assert not link.armed


@pytest.mark.parametrize("vehicle_link", [
    (8, MAV.MAV_RESULT_ACCEPTED, {"command_timeout": 5.0, "progress_timeout": 60.0})],
    indirect=True)
def test_a_command_that_finishes_within_its_budget_is_waited_for(
        vehicle_link: tuple[MavlinkLink, ProgressVehicle]) -> None:
    link, vehicle = vehicle_link
    link.arm()
    assert link.armed and vehicle.acks_sent == 9  # 8 IN_PROGRESS, then ACCEPTED


def test_the_budget_is_a_checked_link_option() -> None:
    from mrss.errors import ConfigError
    with pytest.raises(ConfigError, match="progress_timeout.*positive"):
        create_link("uav7", "mavlink", {"url": "udpin:127.0.0.1:1", "progress_timeout": 0})
