"""The wildfire project with every guard on, under `mrss supervise`: MAVLink signing
between the simulated UAV and its link, the world model's HTTP API on 0.0.0.0 with a
token, and the embedded broker with a password file. The mission starts as usual: both
robots report to the world model, an operator's area goal is flown, and the hotspot
found gets water."""

from __future__ import annotations

import secrets
import shutil
from pathlib import Path

import pytest

from mrss.api.testing import RunningProject
from mrss.edge.broker_auth import add_user
from mrss.edge.worldmodel_access import WorldModelClient, WorldModelRejected

WILDFIRE = Path(__file__).resolve().parents[2] / "projects" / "wildfire"
AREA = {"goal": "a1", "priority": 2, "center": [-35.360567, 149.165237], "radius": 100}
PASSWORD = "mqtt-" + secrets.token_urlsafe(12)


def secured_copy(root: Path) -> Path:
    folder = root / "projects" / "wildfire_secured"
    shutil.copytree(WILDFIRE, folder, ignore=shutil.ignore_patterns("__pycache__",
                                                                     "procedures"))
    (folder / "keys").mkdir()
    (folder / "keys" / "uav1.key").write_text(secrets.token_hex(32) + "\n")
    (folder / "secrets").mkdir()
    (folder / "secrets" / "worldmodel.token").write_text(secrets.token_urlsafe(32) + "\n")
    add_user(folder / "secrets" / "mqtt.passwd", "ops", PASSWORD)
    for path in (*folder.glob("keys/*"), *folder.glob("secrets/*")):
        path.chmod(0o600)
    toml = (folder / "project.toml").read_text()
    for old, new in (
        ('id = "uav1"\n', 'id = "uav1"\nsigning_key = "keys/uav1.key"\n'),
        ('link = "mavlink"', 'signing_key = "keys/uav1.key"\nlink = "mavlink"'),
        ('[worldmodel]\n', '[worldmodel]\nhttp_host = "0.0.0.0"\n'
                           'token_file = "secrets/worldmodel.token"\n'),
        ('[events]\n', '[broker]\nusername = "ops"\npassword_env = "MRSS_TEST_MQTT_PASSWORD"\n'
                       '[broker.embedded]\npassword_file = "secrets/mqtt.passwd"\n\n[events]\n'),
    ):
        assert toml.count(old) == 1, old
        toml = toml.replace(old, new)
    (folder / "project.toml").write_text(toml)
    return folder


@pytest.mark.slow
def test_the_wildfire_mission_runs_with_every_guard_on(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MRSS_TEST_MQTT_PASSWORD", PASSWORD)   # for this process's publish
    project = secured_copy(tmp_path)
    with RunningProject(project, tmp_path / "run", env={"MRSS_SIM_SPEEDUP": "8"}) as system:
        system.wait_ready(timeout=60)
        # the data layer stores telemetry; the world model answers only with the token
        system.wait_for(lambda: (system.world("uav1") or {}).get("position"), 30,
                        "UAV telemetry (signed MAVLink) in the world model")
        system.wait_for(lambda: (system.world("ugv1") or {}).get("position"), 30,
                        "UGV telemetry (MQTT with the project's login) in the world model")
        assert system.file("worldmodel.url").startswith("http://0.0.0.0:")
        with pytest.raises(WorldModelRejected, match="HTTP 401"):
            WorldModelClient(run_dir=system.run_dir, timeout=5).get("uav1")
        # the operator's goal: MQTT with the login -> events -> world model (token) -> cover
        system.publish("mrss/ui/area", AREA)
        system.wait_for(lambda: system.statuses("uav1", "succeeded"), 90,
                        "the area covered (signed commands obeyed)")
        system.wait_for(lambda: system.statuses("ugv1", "succeeded"), 90,
                        "water on the hotspot found (the UGV over MQTT with the login)")
        assert not system.statuses(state="failed"), system.log()
        assert "refused MAVLink messages" not in system.log(tail=200_000)
        assert system.interrupt() == 0, system.log()
