"""The RCL behind a real ZeroMQ bus (in-process proxy): requests on the reliable channel,
controls and teleop on pub/sub, statuses back on action.status."""

from __future__ import annotations

import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from mrss.actors.rcl.service import RclService
from mrss.bus import BusEndpoints, ProxyThread, Publisher, ReliableSender, Subscriber
from mrss.errors import ConfigError
from mrss.messages import (
    ActionControl,
    ActionRequest,
    ActionStatus,
    Command,
    Envelope,
    Heartbeat,
)
from mrss.runtime.component import ComponentContext
from mrss.testing import wait_until

PROJECT = Path(__file__).parent / "rcl_project"


def _ctx(name: str, inc: int, project_dir: Path, run_dir: Path, bus: dict[str, Any],
        options: dict[str, Any] | None = None) -> ComponentContext:
    """The start context the supervisor gives a component."""
    return ComponentContext(name, inc, project_dir, run_dir, bus=bus, options=options or {})


class Statuses:
    def __init__(self) -> None:
        self.envs: list[Envelope] = []

    def __call__(self, env: Envelope) -> None:
        self.envs.append(env)

    def states(self, uuid: str) -> list[str]:
        """The transitions of `uuid` (not progress or reconciliation repeats)."""
        return [e.body.state for e in list(self.envs)
                if isinstance(e.body, ActionStatus) and e.body.uuid == uuid
                and not e.body.repeat]

    def last(self, uuid: str) -> ActionStatus | None:
        found = [e.body for e in list(self.envs)
                 if isinstance(e.body, ActionStatus) and e.body.uuid == uuid]
        return found[-1] if found else None


@pytest.fixture()
def bus() -> Iterator[tuple[BusEndpoints, Path]]:
    run_dir = Path(tempfile.mkdtemp(prefix="mrss-rcl-"))  # short: ipc path limit
    endpoints = BusEndpoints.ipc(run_dir)
    try:
        with ProxyThread(endpoints):
            yield endpoints, run_dir
    finally:
        shutil.rmtree(run_dir, ignore_errors=True)


def test_rcl_service_end_to_end_over_the_bus(bus: tuple[BusEndpoints, Path]) -> None:
    endpoints, run_dir = bus
    options = {"robots": {"ugv1": {"leg": 0.01}, "uav1": {"leg": 0.01}}, "adopt_grace": 0.3}
    ctx = _ctx("rcl", 1, PROJECT, run_dir, endpoints.to_dict(), options)
    service = RclService()
    statuses = Statuses()
    sub = Subscriber(endpoints, prefixes=["action.status", "sup.heartbeat.rcl"])
    tx = ReliableSender(endpoints, src="reasoner", inc=1, channel="action")
    ctl = Publisher(endpoints, src="reasoner", inc=1)
    service.start(ctx)
    try:
        sub.start(statuses)
        assert sub.wait_connected(5) and ctl.wait_connected(5)
        tx.send(ActionRequest(uuid="a1", name="patrol", args=["ugv1", "g1", [1, 2, 3]]))
        tx.send(ActionRequest(uuid="x1", name="explode", args=["uav1", "g2"]))
        tx.send(ActionRequest(uuid="bad", name="patrol", args=[]))
        wait_until(lambda: statuses.states("a1")[-1:] == ["succeeded"], message="a1 done")
        wait_until(lambda: statuses.states("x1")[-1:] == ["failed"])
        wait_until(lambda: statuses.states("bad") == ["failed"])
        assert statuses.states("a1") == ["pending", "running", "succeeded"]
        x1 = statuses.last("x1")
        assert x1 is not None and "ValueError: gearbox jammed" in x1.reason
        assert tx.pending() == 0
        assert all(e.src == "rcl" and e.inc == 1 for e in statuses.envs)
        wait_until(lambda: any(isinstance(e.body, Heartbeat) for e in statuses.envs),
                   message="the RCL's heartbeat (the reasoner's lease)")

        # goal management and teleop on pub/sub
        tx.send(ActionRequest(uuid="a2", name="patrol", args=["ugv1", "g3", list(range(500))]))
        wait_until(lambda: statuses.states("a2")[-1:] == ["running"])
        ctl.publish(Command(command="teleop", target="ugv1", args={"on": True}))
        wait_until(lambda: statuses.states("a2")[-1:] == ["suspended"])
        ctl.publish(Command(command="teleop", target="ugv1", args={"on": False}))
        wait_until(lambda: statuses.states("a2")[-1:] == ["running"])
        ctl.publish(ActionControl(command="cancel", target="g3", target_kind="goal"))
        wait_until(lambda: statuses.states("a2")[-1:] == ["cancelled"])
        assert statuses.states("a2") == ["pending", "running", "suspended", "running",
                                         "cancelled"]

        # a new incarnation of the reasoner: its predecessor's actions are orphans, cancelled
        # when nobody adopted them within the grace
        tx.send(ActionRequest(uuid="a3", name="patrol", args=["uav1", "g4", list(range(500))]))
        wait_until(lambda: statuses.states("a3")[-1:] == ["running"])
        # ... announced by its first heartbeat
        with Publisher(endpoints, src="reasoner", inc=2) as pub2:
            assert pub2.wait_connected(5)
            pub2.publish(Heartbeat(component="reasoner", pid=1))
            wait_until(lambda: statuses.states("a3")[-1:] == ["cancelled"])
        last = statuses.last("a3")
        assert last is not None and "orphaned: reasoner incarnation 1" in last.reason
        tx2 = ReliableSender(endpoints, src="reasoner", inc=2, channel="action")
        try:
            tx2.send(ActionRequest(uuid="a4", name="patrol", args=["ugv1", "g5", [1]]))
            wait_until(lambda: statuses.states("a4")[-1:] == ["succeeded"])
            # a late request of the dead incarnation 1: acknowledged, never run
            tx.send(ActionRequest(uuid="late1", name="patrol", args=["ugv1", "g6", [1]]))
            wait_until(lambda: tx.pending() == 0, message="late1 acknowledged")
            assert service.incarnations.dropped == 1 and statuses.states("late1") == []

            # the RCL restarts: from its journal it knows incarnation 1 is gone
            service.stop()
            ctx.publisher.close()
            ctx = _ctx("rcl", 2, PROJECT, run_dir, endpoints.to_dict(), options)
            service = RclService()
            service.start(ctx)
            assert service.incarnations.live("reasoner") == 2
            tx.send(ActionRequest(uuid="late2", name="patrol", args=["ugv1", "g7", [1]]))
            tx2.send(ActionRequest(uuid="a5", name="patrol", args=["ugv1", "g8", [1]]))
            wait_until(lambda: statuses.states("a5")[-1:] == ["succeeded"])
            wait_until(lambda: tx.pending() == 0, message="late2 acknowledged")
            assert statuses.states("late2") == [] and service.incarnations.dropped == 1
        finally:
            tx2.close()
    finally:
        tx.close()
        ctl.close()
        sub.close()
        service.stop()
        ctx.publisher.close()
    assert all(link.closed for link in service.links.values())


def test_rcl_service_refuses_a_project_without_robots(bus: tuple[BusEndpoints, Path]) -> None:
    endpoints, run_dir = bus
    with pytest.raises(ConfigError, match="robots"):
        RclService().start(_ctx("rcl", 1, PROJECT, run_dir, endpoints.to_dict()))
    with pytest.raises(ConfigError, match="no such file"):
        RclService().start(_ctx("rcl", 1, run_dir, run_dir, endpoints.to_dict(),
                               {"robots": {"ugv1": {}}}))
