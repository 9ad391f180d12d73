"""The template_sims DriveTo skill waits for its link before its first command: an action
that a restarted RCL resumes starts while the new MQTT link still connects (chaos,
wildfire's fix of the same defect). Real RCL core, MQTT link, broker and UGV simulator;
the simulator starts only once the skill runs, so the link is down ("connecting") then.
Before the fix the action failed at once, link_down "connecting to ...".
"""

from __future__ import annotations

from pathlib import Path

from mrss.api import distance_m, import_project_module
from mrss.links.mqtt import MqttLink
from mrss.sim.ugv import DEFAULT_BASE, SimUgv
from mrss.testing import BrokerInfo, wait_until
from tests.actors.rcl.rcl_sim import RclEnv, request_fields

TEMPLATE = Path(__file__).resolve().parents[3] / "projects" / "template_sims"
skills = import_project_module(TEMPLATE, "skills.py")
TARGET = (DEFAULT_BASE[0] + 0.0001, DEFAULT_BASE[1])  # ~11 m north of the base


def test_drive_to_waits_for_a_link_still_connecting_and_then_drives(
        mqtt_broker: BrokerInfo, tmp_path: Path) -> None:
    link = MqttLink("ugv1", mqtt_broker.url)
    sim = SimUgv(mqtt_broker.url, "ugv1", speedup=10.0, telemetry_hz=5.0)
    env = RclEnv(tmp_path / "journal.sqlite3", {})
    env.layer.recipes["drive"] = lambda a: [skills.DriveTo(*TARGET)]
    link.start()
    try:
        core = env.start(robots={"ugv1": link})
        core.submit_fields(request_fields("d1", "drive", "ugv1", "g1", *TARGET))
        wait_until(lambda: {"running", "failed"} & set(env.statuses.states("d1")),
                   message="the drive running")
        assert env.statuses.states("d1") == ["pending", "running"], env.statuses.last("d1")
        assert not link.up  # no robot yet: the skill's first command would fail now
        sim.start()
        wait_until(lambda: (env.statuses.last("d1") or env.statuses.of("d1")[0]).state
                   in ("succeeded", "failed"), timeout=20, message="the drive to end")
        last = env.statuses.last("d1")
        assert last is not None and last.state == "succeeded", last
        at = sim.snapshot()
        assert distance_m(at.lat, at.lon, *TARGET) <= 3.0
    finally:
        env.stop()
        link.close()
        sim.stop()
