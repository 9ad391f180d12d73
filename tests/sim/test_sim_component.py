"""The simulated robots as components: address file, port reuse, options, real links."""

from __future__ import annotations

import secrets
from pathlib import Path
from typing import Any

import pytest

from mrss.errors import ConfigError
from mrss.links.connect import connect_link
from mrss.links.mavlink import MavlinkLink
from mrss.links.mqtt import MqttLink
from mrss.runtime.component import ComponentContext
from mrss.sim.component import SimUavComponent, SimUgvComponent, speedup_of
from mrss.testing import BrokerInfo, WaitTimeout, wait_until


def context(tmp_path: Path, name: str, **options: Any) -> ComponentContext:
    run_dir = tmp_path / "run"
    run_dir.mkdir(exist_ok=True)
    return ComponentContext(name=name, incarnation=1, project_dir=tmp_path, run_dir=run_dir,
                            options=dict(options))


@pytest.mark.slow
def test_uav_writes_its_address_and_a_restart_reuses_the_port(tmp_path: Path) -> None:
    ctx = context(tmp_path, "sim_uav", id="uav7", home=[47.0, 8.0], speedup=5,
                  hotspots=[{"lat": 47.001, "lon": 8.0}])
    sim = SimUavComponent()
    sim.start(ctx)
    link: MavlinkLink | None = None
    try:
        address = (ctx.run_dir / "uav7.mavlink").read_text().strip()
        assert address.startswith("udpout:127.0.0.1:")
        link = MavlinkLink("uav7", address, heartbeat_timeout=2.0)
        link.start()
        link.wait_up(10)
        wait_until(lambda: link is not None and link.latest("position") is not None, 5,
                   message="position telemetry")
        position = link.latest("position")
        assert position is not None and abs(position["lat"] - 47.0) < 1e-6
        assert sim.healthy()
        sim.stop()
        wait_until(lambda: link is not None and not link.up, 10, message="the link to drop")
        again = SimUavComponent()                     # the next incarnation of this run
        again.start(ctx)
        try:
            assert (ctx.run_dir / "uav7.mavlink").read_text().strip() == address
            wait_until(lambda: link is not None and link.up, 10, message="the link back up")
        finally:
            again.stop()
    finally:
        if link is not None:
            link.close()
        sim.stop()


def test_uav_ground_crew_recharges_at_home_only(tmp_path: Path) -> None:
    sim = SimUavComponent()
    sim.start(context(tmp_path, "sim_uav", speedup=50, recharge=10.0))
    try:
        assert sim.uav is not None
        model = sim.uav.model
        model.battery_pct = 40.0
        wait_until(lambda: model.battery_pct >= 99.0, 10, message="the battery swap")
        model.lat += 0.01                               # ~1 km from home: nobody there
        model.battery_pct = 40.0
        with pytest.raises(WaitTimeout):
            wait_until(lambda: model.battery_pct > 41.0, 0.5, message="no recharge away")
    finally:
        sim.stop()


def test_ugv_joins_the_projects_broker(tmp_path: Path, mqtt_broker: BrokerInfo) -> None:
    ctx = context(tmp_path, "sim_ugv", id="ugv7", base="47.0,8.0", speedup=10, tank=50)
    (ctx.run_dir / "broker.url").write_text(mqtt_broker.url + "\n")
    sim = SimUgvComponent()
    sim.start(ctx)
    link = MqttLink("ugv7", mqtt_broker.url)
    try:
        link.start()
        link.wait_up(10)
        wait_until(lambda: link.latest("tank") is not None, 5, message="tank telemetry")
        tank = link.latest("tank")
        assert tank is not None and tank["capacity"] == 50.0
        assert sim.healthy()
    finally:
        link.close()
        sim.stop()


@pytest.mark.parametrize(("options", "key"), [
    ({"home": [91.0, 0.0]}, "home"),
    ({"home": "north"}, "home"),
    ({"speedup": 0}, "speedup"),
    ({"recharge": -1}, "recharge"),
    ({"hotspots": 7}, "hotspots"),
    ({"signing_key": "keys/none.key"}, "signing_key"),
])
def test_bad_options_name_their_key(tmp_path: Path, options: dict[str, Any],
                                    key: str) -> None:
    with pytest.raises(ConfigError) as info:
        SimUavComponent().start(context(tmp_path, "sim_uav", **options))
    assert info.value.key == key


def test_signed_uav_component_and_the_robot_table_share_a_project_key_file(
        tmp_path: Path) -> None:
    (tmp_path / "keys").mkdir()
    (tmp_path / "keys" / "uav1.key").write_text(secrets.token_hex(32) + "\n")
    ctx = context(tmp_path, "sim_uav", speedup=5, signing_key="keys/uav1.key")
    sim = SimUavComponent()
    sim.start(ctx)
    links = []
    try:
        for table in ({"link": "mavlink", "signing_key": "keys/uav1.key"}, {"link": "mavlink"}):
            link = connect_link("uav1", table, project_dir=tmp_path, run_dir=ctx.run_dir)
            assert isinstance(link, MavlinkLink)
            links.append(link)
        signed, unsigned = links
        signed.wait_up(10)
        signed.set_mode("GUIDED")                  # a signed command is obeyed
        wait_until(lambda: sim.uav is not None and sim.uav.snapshot().mode == "GUIDED", 5,
                   message="GUIDED")
        wait_until(lambda: sim.uav is not None and sim.uav.refused()["unsigned"] >= 2, 10,
                   message="the unsigned link's heartbeats refused")
        # A sender whose datagrams are all refused never becomes the vehicle's peer: the
        # unsigned link hears nothing, while the signed one stays up.
        assert not unsigned.up and unsigned.target_system is None
        assert signed.up and sim.uav is not None and sim.uav.snapshot().mode == "GUIDED"
        sim.stop()                                 # a new incarnation signs with a new
        wait_until(lambda: not signed.up, 15, message="the link to drop")  # timestamp
        sim = SimUavComponent()
        sim.start(ctx)
        wait_until(lambda: signed.up, 15, message="the signed link back up")
        assert signed.refused()["replayed"] == 0
    finally:
        for link in links:
            link.close()
        sim.stop()


def test_ugv_without_a_broker_says_how_to_get_one(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="no MQTT broker"):
        SimUgvComponent().start(context(tmp_path, "sim_ugv"))


def test_speedup_environment_overrides_the_option(monkeypatch: pytest.MonkeyPatch) -> None:
    assert speedup_of({"speedup": 3}) == 3.0
    monkeypatch.setenv("MRSS_SIM_SPEEDUP", "20")
    assert speedup_of({"speedup": 3}) == 20.0
    monkeypatch.setenv("MRSS_SIM_SPEEDUP", "fast")
    with pytest.raises(ConfigError):
        speedup_of({})
