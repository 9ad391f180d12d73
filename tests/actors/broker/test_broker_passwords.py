"""The embedded MQTT broker with a password file, as a real process, with real clients:
anonymous and wrong logins refused, the project's own clients (an MQTT robot link and the
simulated UGV) logged in with the project's [broker] login."""

from __future__ import annotations

import json
import subprocess
import sys
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from paho.mqtt import client as mqtt
from paho.mqtt.enums import CallbackAPIVersion

from mrss.actors.broker.passwords import password_file_problem, read_users
from mrss.config.broker import BROKER_URL_FILE
from mrss.config.kinds import KINDS, ComponentKind
from mrss.links.connect import connect_link
from mrss.links.mqtt import MqttLink
from mrss.runtime.component import ComponentContext
from mrss.sim.component import SimUgvComponent
from mrss.testing import wait_until

PASSWORD = "correct horse battery staple"
PROJECT_TOML = """\
[broker]
username = "ops"
password_env = "MRSS_TEST_MQTT_PASSWORD"
[broker.embedded]
password_file = "secrets/mqtt.passwd"
"""


def add_user(path: Path, user: str, password: str) -> None:
    out = subprocess.run([sys.executable, "-m", "mrss.actors.broker.passwords", str(path), user],
                         input=password + "\n", capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr


@pytest.fixture()
def guarded_broker(tmp_path: Path, monkeypatch: pytest.MonkeyPatch
                   ) -> Iterator[tuple[Path, Path, str]]:
    project, run_dir = tmp_path / "project", tmp_path / "run"
    (project / "secrets").mkdir(parents=True)
    run_dir.mkdir()
    (project / "project.toml").write_text(PROJECT_TOML)
    add_user(project / "secrets" / "mqtt.passwd", "ops", PASSWORD)
    add_user(project / "secrets" / "mqtt.passwd", "viewer", "another one")
    monkeypatch.setenv("MRSS_TEST_MQTT_PASSWORD", PASSWORD)
    ctx = ComponentContext(name="broker", incarnation=1, project_dir=project, run_dir=run_dir)
    log = open(tmp_path / "broker.log", "wb")  # noqa: SIM115 (kept by Popen)
    proc = subprocess.Popen([sys.executable, "-m", "mrss.runtime.main",
                             KINDS[ComponentKind.BROKER].target, "--name", "broker",
                             "--context", ctx.to_json()], stdout=log, stderr=subprocess.STDOUT)
    log.close()
    try:
        url_file = run_dir / BROKER_URL_FILE
        wait_until(url_file.is_file, timeout=30,
                   message=f"broker URL\n{(tmp_path / 'broker.log').read_text()}")
        yield project, run_dir, url_file.read_text().strip()
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def connect(url: str, user: str | None, password: str | None) -> tuple[bool, str]:
    """(accepted, reason) of one MQTT connection attempt."""
    host, port = url.removeprefix("mqtt://").rsplit(":", 1)
    answer: dict[str, Any] = {}
    done = threading.Event()

    def on_connect(client: mqtt.Client, userdata: Any, flags: Any, reason: Any,
                   properties: Any) -> None:
        answer["ok"], answer["reason"] = not reason.is_failure, str(reason)
        done.set()

    client = mqtt.Client(CallbackAPIVersion.VERSION2, client_id=f"t-{user}")
    if user is not None:
        client.username_pw_set(user, password)
    client.on_connect = on_connect
    client.connect(host, int(port))
    client.loop_start()
    try:
        wait_until(done.is_set, timeout=20, message="CONNACK")
    finally:
        client.disconnect()  # first: a loop stopped first sits out its 1 s select
        client.loop_stop()
    return answer["ok"], answer["reason"]


def test_only_users_of_the_password_file_get_in(
        guarded_broker: tuple[Path, Path, str]) -> None:
    _, _, url = guarded_broker
    for user, password in ((None, None), ("ops", "wrong"), ("intruder", PASSWORD),
                           ("viewer", PASSWORD)):
        ok, reason = connect(url, user, password)
        assert not ok and "authorized" in reason.lower(), (user, reason)
    assert connect(url, "ops", PASSWORD)[0]
    assert connect(url, "viewer", "another one")[0]


@pytest.mark.slow
def test_the_projects_own_clients_log_in_with_its_broker_login(
        guarded_broker: tuple[Path, Path, str]) -> None:
    project, run_dir, url = guarded_broker
    ugv = SimUgvComponent()
    ugv.start(ComponentContext(name="sim_ugv", incarnation=1, project_dir=project,
                               run_dir=run_dir, options={"id": "ugv1", "speedup": 5}))
    link = None
    try:
        link = connect_link("ugv1", {"link": "mqtt"}, project_dir=project, run_dir=run_dir)
        assert isinstance(link, MqttLink) and link.address.username == "ops"
        link.wait_up(20)                  # telemetry of the simulated UGV through the broker
        assert link.latest("position") is not None
    finally:
        if link is not None:
            link.close()
        ugv.stop()
    assert "ops" not in url and PASSWORD not in (run_dir / BROKER_URL_FILE).read_text()


def test_password_files_are_checked(tmp_path: Path) -> None:
    path = tmp_path / "mqtt.passwd"
    assert "cannot read password file" in (password_file_problem(path) or "")
    path.write_text("# nobody yet\n")
    assert "names no user" in (password_file_problem(path) or "")
    path.write_text("ops:plaintext\n")
    assert "line 1 must be user:$argon2id$" in (password_file_problem(path) or "")
    add_user(path, "ops", PASSWORD)
    add_user(path, "ops", "changed")                  # a user's line is replaced
    assert list(read_users(path)) == ["ops"] and password_file_problem(path) is None
    assert path.stat().st_mode & 0o077 == 0


def test_mrss_check_wants_the_projects_login_with_a_password_file(tmp_path: Path) -> None:
    folder = tmp_path / "projects" / "guarded"
    (folder / "secrets").mkdir(parents=True)
    add_user(folder / "secrets" / "mqtt.passwd", "ops", PASSWORD)
    (folder / "project.toml").write_text(
        '[components.broker]\nkind = "broker"\n'
        '[broker.embedded]\npassword_file = "secrets/mqtt.passwd"\n')
    out = subprocess.run([sys.executable, "-m", "mrss", "check", "guarded", "--json"],
                         capture_output=True, text=True, timeout=120,
                         env={"MRSS_PROJECTS": str(folder.parent), "PATH": "/usr/bin:/bin"})
    assert out.returncode == 2, out.stderr
    errors = [f for f in json.loads(out.stdout)["findings"] if f["severity"] == "error"]
    assert [(e["key"], e["line"]) for e in errors] == [("broker.embedded.password_file", 4)]
    assert "set username and password_env" in errors[0]["message"]
    (folder / "project.toml").write_text(PROJECT_TOML.replace(
        "[broker]", '[components.broker]\nkind = "broker"\n[broker]'))
    (folder / "secrets" / "mqtt.passwd").chmod(0o644)
    out = subprocess.run([sys.executable, "-m", "mrss", "check", "guarded", "--json"],
                         capture_output=True, text=True, timeout=120,
                         env={"MRSS_PROJECTS": str(folder.parent), "PATH": "/usr/bin:/bin"})
    report = json.loads(out.stdout)
    assert report["ok"], out.stdout
    assert [(f["severity"], f["key"]) for f in report["findings"]] == [
        ("warning", "broker.embedded.password_file")]
    assert "chmod 600" in report["findings"][0]["message"]
