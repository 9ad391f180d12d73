"""MQTT robot links over TLS with per-robot credentials (issue 15 item 3), on a private
Mosquitto that has only a TLS listener, a password file and an ACL giving each robot's
login its own topics (`pattern readwrite mrss/robots/%u/#`). Certificates: a test CA
made by openssl signs the broker's; a second CA plays the wrong one."""

from __future__ import annotations

import getpass
import subprocess
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

from mrss.errors import ConfigError
from mrss.links.connect import connect_link
from mrss.links.factory import create_link
from mrss.links.mqtt import MqttLink
from mrss.links.mqtt_url import BrokerAddress, new_client
from mrss.links.ugv_protocol import UgvTelemetry, UgvTopics
from mrss.runtime.component import ComponentContext
from mrss.sim.component import SimUgvComponent
from mrss.sim.ugv import main as ugv_main
from mrss.testing import find_mosquitto, free_port, wait_until
from tests.mosquitto import require_mosquitto

from .test_mavlink_link import Recorder

FORGED_LAT = -10.0  # far from the simulator's base: a forged record would show


@dataclass(frozen=True)
class TlsBroker:
    port: int
    dir: Path

    @property
    def url(self) -> str:
        return f"mqtts://127.0.0.1:{self.port}"

    def file(self, name: str) -> str:
        return str(self.dir / name)


def _openssl(d: Path, *args: str) -> None:
    subprocess.run(["openssl", *args], cwd=d, check=True, capture_output=True)


def _ca(d: Path, name: str) -> None:
    _openssl(d, "req", "-x509", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1",
             "-nodes", "-days", "1", "-keyout", f"{name}.key", "-out", f"{name}.pem",
             "-subj", f"/CN={name}")


@pytest.fixture(scope="module")
def tls_broker() -> Iterator[TlsBroker]:
    binary = require_mosquitto(find_mosquitto(), "the TLS tests",
                               ("mosquitto_passwd", "openssl"))
    with tempfile.TemporaryDirectory(prefix="mrss-tls-") as tmp:
        d = Path(tmp)
        _ca(d, "ca")
        _ca(d, "other-ca")
        _openssl(d, "req", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1",
                 "-nodes", "-keyout", "server.key", "-out", "server.csr",
                 "-subj", "/CN=localhost")
        (d / "san.ext").write_text("subjectAltName=IP:127.0.0.1,DNS:localhost\n")
        _openssl(d, "x509", "-req", "-in", "server.csr", "-CA", "ca.pem", "-CAkey", "ca.key",
                 "-CAcreateserial", "-days", "1", "-out", "server.pem", "-extfile", "san.ext")
        passwd = d / "passwd"
        for user, password in (("ugv1", "pw-ugv1"), ("ugv2", "pw-ugv2")):
            subprocess.run(["mosquitto_passwd", "-b", *(["-c"] if user == "ugv1" else []),
                            str(passwd), user, password], check=True, capture_output=True)
            (d / f"{user}.pass").write_text(password + "\n")
        (d / "wrong.pass").write_text("not-the-password\n")
        (d / "acl").write_text("pattern readwrite mrss/robots/%u/#\n")
        for name in ("passwd", "acl", "ugv1.pass", "ugv2.pass", "wrong.pass"):
            (d / name).chmod(0o600)
        port = free_port()
        (d / "mosquitto.conf").write_text(
            f"user {getpass.getuser()}\nper_listener_settings false\nallow_anonymous false\n"
            f"password_file {passwd}\nacl_file {d / 'acl'}\npersistence false\n"
            f"log_type error\nset_tcp_nodelay true\n"
            f"listener {port} 127.0.0.1\ncafile {d / 'ca.pem'}\n"
            f"certfile {d / 'server.pem'}\nkeyfile {d / 'server.key'}\n")
        proc = subprocess.Popen([binary, "-c", str(d / "mosquitto.conf")],
                                stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        try:
            broker = TlsBroker(port, d)
            wait_until(lambda: _tls_login_works(broker), timeout=10,
                       message="the TLS mosquitto answering")
            yield broker
        finally:
            proc.terminate()
            try:
                proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()


def _tls_login_works(broker: TlsBroker) -> bool:
    client = new_client("probe", BrokerAddress("127.0.0.1", broker.port, "ugv1", "pw-ugv1",
                                               True, broker.file("ca.pem")))
    try:
        ok = client.connect("127.0.0.1", broker.port, keepalive=5) == 0
    except OSError:
        return False
    finally:
        client.disconnect()
    return ok


def _login(broker: TlsBroker, user: str, password: str | None = None) -> dict[str, str]:
    return {"username": user, "password_file": broker.file(password or f"{user}.pass"),
            "ca_certs": broker.file("ca.pem")}


def test_a_robot_link_over_tls_with_its_own_login_and_the_acl_stops_another_robot(
        tls_broker: TlsBroker) -> None:
    # as a project names them: files relative to the project folder (here the broker's)
    login = {"broker_url": tls_broker.url, "username": "ugv1", "password_file": "ugv1.pass",
             "ca_certs": "ca.pem"}
    sim = SimUgvComponent()
    sim.start(ComponentContext(name="sim_ugv", incarnation=1, project_dir=tls_broker.dir,
                               run_dir=tls_broker.dir, options={
                                   "id": "ugv1", "speedup": 20, "rate": 10, **login}))
    rec = Recorder()
    link = connect_link("ugv1", {"link": "mqtt", **login}, project_dir=tls_broker.dir,
                        run_dir=tls_broker.dir, on_link_state=rec.on_state,
                        on_telemetry=rec.on_telemetry)
    assert isinstance(link, MqttLink) and link.address.tls
    assert link.address.ca_certs == tls_broker.file("ca.pem")
    forger = new_client("forger", BrokerAddress("127.0.0.1", tls_broker.port, "ugv2",
                                                "pw-ugv2", True, tls_broker.file("ca.pem")))
    try:
        link.wait_up(timeout=20)
        assert link.goto(-35.3630, 149.1650).status == "done"  # commands go through TLS

        # ugv2's login may not write ugv1's topics: the broker drops the forgery.
        forger.connect("127.0.0.1", tls_broker.port, keepalive=5)
        forger.loop_start()
        forged = UgvTelemetry("ugv1", 1.0, FORGED_LAT, 149.0, 0.0, 0.0, 90.0, 50.0, 50.0,
                              False, "idle", True, False).to_json()
        info = forger.publish(UgvTopics.for_robot("ugv1").telemetry, forged, qos=1)
        info.wait_for_publish(timeout=10)
        assert info.is_published()  # acknowledged (MQTT 3.1.1 acks a denied publish too)
        seen = len(rec.of_type("position"))
        wait_until(lambda: len(rec.of_type("position")) >= seen + 3, timeout=10,
                   message="genuine telemetry after the forgery")
        assert all(r["lat"] != FORGED_LAT for r in rec.of_type("position"))
        assert link.bad_messages == 0
    finally:
        forger.disconnect()  # first: a loop stopped first sits out its 1 s select
        forger.loop_stop()
        link.close()
        sim.stop()


def test_the_simulator_command_takes_the_login_and_refuses_a_missing_file(
        capsys: pytest.CaptureFixture[str]) -> None:
    assert ugv_main(["--broker", "mqtts://127.0.0.1:8883", "--username", "ugv1",
                     "--password-file", "/nonexistent/ugv1.pass"]) == 2
    assert "cannot read the password file '/nonexistent/ugv1.pass'" in capsys.readouterr().err


def test_a_wrong_password_or_ca_keeps_the_link_down_with_the_reason(
        tls_broker: TlsBroker) -> None:
    wrong_password = create_link("ugv2", "mqtt", {
        "broker_url": tls_broker.url, **_login(tls_broker, "ugv2", "wrong.pass")})
    wrong_ca = create_link("ugv2", "mqtt", {
        "broker_url": tls_broker.url, **_login(tls_broker, "ugv2"),
        "ca_certs": tls_broker.file("other-ca.pem")})
    for link in (wrong_password, wrong_ca):
        link.start()
    try:
        wait_until(lambda: "Not authorized" in wrong_password.reason, timeout=15,
                   message=f"a refused login: {wrong_password.reason}")
        wait_until(lambda: "(TLS: is ca_certs the broker's CA?)" in wrong_ca.reason,
                   timeout=15, message=f"a refused certificate: {wrong_ca.reason}")
        assert not wrong_password.up and not wrong_ca.up
    finally:
        for link in (wrong_password, wrong_ca):
            link.close()
    with pytest.raises(ConfigError, match="cannot read the password file") as missing:
        create_link("ugv2", "mqtt", {"broker_url": tls_broker.url,
                                     "password_file": tls_broker.file("nope.pass")},
                    source="project.toml")
    assert missing.value.key == "password_file" and missing.value.file == "project.toml"
    with pytest.raises(ConfigError, match="keyfile needs certfile"):
        create_link("ugv2", "mqtt", {"broker_url": tls_broker.url,
                                     "keyfile": tls_broker.file("ca.key")})
