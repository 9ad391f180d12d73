"""The wildfire Pump skill on a robot that freezes right after pumping began (chaos: its
simulator SIGSTOPped): the real RCL core, the real MQTT link and broker, the real UGV
simulator, frozen in process the way SIGSTOP freezes it (no step, no telemetry, no answer).

Before the fix, the skill read the tank record from before its pump command
("pumping": false) and failed the action plainly, "pump stopped after 0 of 10 l"; now
stale telemetry fails it `transient` (the agent retries), and the retry delivers.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from mrss.api import import_project_module
from mrss.links.mqtt import MqttLink
from mrss.links.ugv_protocol import parse_command
from mrss.sim.ugv import SimUgv
from mrss.testing import BrokerInfo, wait_until
from tests.actors.rcl.rcl_sim import RclEnv, request_fields

WILDFIRE = Path(__file__).resolve().parents[3] / "projects" / "wildfire"
skills = import_project_module(WILDFIRE, "skills.py")


class FreezingUgv(SimUgv):
    """The simulated UGV, frozen (as by SIGSTOP) once it has accepted a pump command:
    it neither moves, pumps, publishes telemetry nor answers until `thaw()`."""

    def __init__(self, *args: object, **kwargs: object) -> None:
        super().__init__(*args, **kwargs)  # type: ignore[arg-type]
        self.gate = threading.Lock()  # frozen is set before any later tick can publish
        self.frozen = threading.Event()
        self.freeze_on_pump = True

    def tick(self, now: float) -> None:
        with self.gate:
            if not self.frozen.is_set():
                super().tick(now)

    def _handle_command(self, payload: bytes, topic: str) -> None:
        with self.gate:
            if self.frozen.is_set():
                return
            super()._handle_command(payload, topic)
            command = parse_command(payload, topic)
            if self.freeze_on_pump and command.cmd == "pump" and command.on:
                self.frozen.set()

    def thaw(self) -> None:
        with self.gate:
            self.freeze_on_pump = False
            self._last = time.monotonic()  # no jump of the frozen time (SIGCONT would)
            self.frozen.clear()


@pytest.fixture()
def ugv(mqtt_broker: BrokerInfo, tmp_path: Path) -> Iterator[tuple[RclEnv, FreezingUgv,
                                                                   MqttLink]]:
    sim = FreezingUgv(mqtt_broker.url, "ugv1", speedup=4.0, telemetry_hz=4.0)
    sim.model.lat += 0.001  # at a hotspot ~110 m from its base, where nothing refills it
    # a link that waits long for telemetry: the skill, not the link, must notice
    link = MqttLink("ugv1", mqtt_broker.url, telemetry_timeout=60.0)
    env = RclEnv(tmp_path / "journal.sqlite3", {})
    env.layer.recipes["pump"] = lambda a: [skills.Pump(float(a.args[2]),  # type: ignore[arg-type]
                                                       stale_s=2.0)]
    sim.start()
    link.start()
    try:
        env.start(robots={"ugv1": link})
        yield env, sim, link
    finally:
        sim.thaw()
        env.stop()
        link.close()
        sim.stop()


def test_pump_on_a_robot_frozen_after_it_began_fails_transient_and_a_retry_delivers(
        ugv: tuple[RclEnv, FreezingUgv, MqttLink]) -> None:
    env, sim, link = ugv
    assert env.core is not None
    link.wait_up(10.0)
    wait_until(lambda: link.latest("tank"), message="tank telemetry")
    full = sim.snapshot().tank
    env.core.submit_fields(request_fields("p1", "pump", "ugv1", "hs1", 10.0))
    wait_until(sim.frozen.is_set, message="the robot frozen after accepting the pump")
    wait_until(env.statuses.reached("p1", "failed"), timeout=20, message="the pump to fail")
    last = env.statuses.last("p1")
    assert last is not None
    assert last.cause == "transient", (last.cause, last.reason)  # was "" (action_failed)
    assert "no tank telemetry" in last.reason and "pump stopped" not in last.reason
    assert link.up  # the link never said the robot was gone: the skill noticed

    sim.thaw()
    thawed = time.time()
    wait_until(lambda: float((link.latest("tank") or {}).get("ts", 0.0)) > thawed,
               message="telemetry again")
    env.core.submit_fields(request_fields("p2", "pump", "ugv1", "hs1", 10.0))
    wait_until(lambda: (env.statuses.last("p2") or last).state in ("succeeded", "failed")
               and env.statuses.last("p2"), timeout=20, message="the retry to end")
    done = env.statuses.last("p2")
    assert done is not None and done.state == "succeeded", done
    assert float(done.progress["pumped"]) >= 9.5  # type: ignore[arg-type]
    assert sim.snapshot().tank <= full - 9.5  # the water did come out
