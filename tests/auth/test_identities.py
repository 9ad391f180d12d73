"""The identity store, `mrss users`, session credentials, the guard's rules, and the
world model's HTTP API with operators' identities."""

from __future__ import annotations

import json
import logging
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from mrss.actors.worldmodel.http import WorldModelHttp
from mrss.actors.worldmodel.model import WorldModel
from mrss.actors.worldmodel.rules import RuleEngine
from mrss.actors.worldmodel.store import WorldModelStore
from mrss.auth.roles import PERMISSIONS, CommandKind, Role, refusal
from mrss.auth.sessions import mint, verify
from mrss.auth.store import AuthError, Identity, OperatorStore, store_path
from mrss.edge.http_token import configured_token
from mrss.errors import ConfigError
from mrss.runtime.operator_guard import LOCAL, OperatorGuard, Verdict
from tests.actors.worldmodel.test_worldmodel_http_guard import HOTSPOT, bearer, request

LOG = logging.getLogger("tests.auth")


def users(tmp_path: Path, *args: str, stdin: str = "") -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "mrss", "users", "p", *args], input=stdin,
                          capture_output=True, text=True, timeout=60,
                          env={**os.environ, "MRSS_PROJECTS": str(tmp_path)})


@pytest.fixture()
def project(tmp_path: Path) -> Path:
    folder = tmp_path / "p"
    folder.mkdir()
    (folder / "project.toml").write_text('[project]\nname = "p"\n')
    return folder


def test_mrss_users_adds_lists_changes_and_removes_operators_stored_hashed(
        tmp_path: Path, project: Path) -> None:
    done = users(tmp_path, "add", "alice", "--role", "commander", stdin="alice-secret-9\n")
    assert done.returncode == 0, done.stderr
    done = users(tmp_path, "add", "bob", "--role", "observer", "--token")
    token = done.stdout.split("token (shown once, keep it secret): ")[1].strip()
    assert token.startswith("mrss_")
    path = store_path(project)
    assert path.stat().st_mode & 0o777 == 0o600
    text = path.read_text()
    assert "alice-secret-9" not in text and token not in text  # hashes only
    assert users(tmp_path, "list").stdout.splitlines() == [
        "alice  commander  password", "bob  observer  token"]
    assert users(tmp_path, "set-role", "bob", "operator").returncode == 0
    store = OperatorStore.load(path)
    assert store.login("alice", "alice-secret-9") == Identity("alice", Role.COMMANDER)
    assert store.by_token(token) == Identity("bob", Role.OPERATOR)
    with pytest.raises(AuthError, match="wrong password or token for 'alice'"):
        store.login("alice", "alice-secret-8")
    bad = users(tmp_path, "remove", "alcie")
    assert bad.returncode == 2 and "no user 'alcie' (did you mean 'alice'?)" in bad.stderr
    short = users(tmp_path, "add", "carl", "--role", "operator", stdin="short\n")
    assert short.returncode == 2 and "at least 8 characters" in short.stderr
    assert users(tmp_path, "remove", "bob").returncode == 0
    with pytest.raises(AuthError, match="unknown token"):
        OperatorStore.load(path).by_token(token)


def test_an_operators_file_open_to_others_is_refused_with_the_fix(
        tmp_path: Path, project: Path) -> None:
    assert users(tmp_path, "add", "alice", "--role", "operator",
                 stdin="alice-secret-9\n").returncode == 0
    path = store_path(project)
    store = OperatorStore.load(path)
    credential = mint(store, Identity("alice", Role.OPERATOR))
    path.chmod(0o644)
    listed = users(tmp_path, "list")
    assert listed.returncode == 2
    assert f"open to others (mode 0644): refused; make it private with chmod 600 {path}" \
        in listed.stderr and "Traceback" not in listed.stderr
    verdict = OperatorGuard(project, LOG).check(credential, CommandKind.TELEOP, "ctl.teleop")
    assert not verdict.ok and "chmod 600" in verdict.reason  # nothing accepted from anyone
    damaged = tmp_path / "damaged.json"
    damaged.write_text("{not json")
    damaged.chmod(0o600)
    with pytest.raises(ConfigError, match="the operators file is damaged"):
        OperatorStore.load(damaged)


def test_a_session_credential_is_checked_against_the_store_now(tmp_path: Path) -> None:
    path = tmp_path / "operators.json"
    store = OperatorStore.new(path).with_user("alice", Role.COMMANDER,
                                              password="alice-secret-9")
    store.save()
    credential = mint(store, Identity("alice", Role.COMMANDER))
    assert verify(store, credential) == Identity("alice", Role.COMMANDER)
    user, expiry = credential.split(":")[1:3]
    forged = credential.replace(f":{expiry}:", f":{int(expiry) + 3600}:")
    for bad, why in ((forged, "not signed by this project's store"),
                     (credential.replace(":alice:", ":bob:"), "not signed"),
                     (mint(store, Identity("alice", Role.COMMANDER), now=time.time() - 86400),
                      r"expired \(log in again\)"),
                     ("s1:alice", "not a session credential"), ("", "no credential")):
        with pytest.raises(AuthError, match=why):
            verify(store, bad)
    demoted = store.with_user("alice", Role.OBSERVER)  # the role is the store's, now
    assert verify(demoted, credential).role is Role.OBSERVER
    ended = store.with_user("alice", Role.COMMANDER, expires=time.time() - 1)
    with pytest.raises(AuthError, match="user 'alice' expired"):
        verify(ended, credential)
    with pytest.raises(AuthError, match="unknown user 'alice'"):
        verify(store.without_user("alice"), credential)


def test_the_role_table_and_the_guards_rules(tmp_path: Path, project: Path) -> None:
    assert PERMISSIONS[Role.OBSERVER] == {CommandKind.READ}
    assert CommandKind.STOP not in PERMISSIONS[Role.OPERATOR]
    assert PERMISSIONS[Role.COMMANDER] == set(CommandKind)
    assert refusal(Role.OPERATOR, CommandKind.MISSION, Role.COMMANDER) == \
        "the operator role may not send it (it needs commander)"
    assert refusal(Role.COMMANDER, CommandKind.MISSION, Role.COMMANDER) == ""
    # no users configured: every command is the local operator's, as before roles
    guard = OperatorGuard(project, LOG)
    assert not guard.active
    assert guard.check("", CommandKind.STOP, "ctl.stop p") == Verdict(True, LOCAL)
    store = OperatorStore.new(store_path(project)).with_user("olga", Role.OBSERVER,
                                                             password="olga-secret-1")
    store.save()
    assert guard.active  # the store is looked for at each check: no restart needed
    olga = mint(store, Identity("olga", Role.OBSERVER))
    assert guard.check(olga, CommandKind.READ, "GET /objects").ok
    verdict = guard.check(olga, CommandKind.STOP, "ctl.stop p")
    assert not verdict.ok and verdict.who == "olga (observer)"
    assert guard.refusals.total == 1
    assert guard.refusals.rejection_counts() == {
        "operator command from olga (observer): ctl.stop p: the observer role may not "
        "send stop commands (only commander)": 1}


def test_the_world_model_api_takes_operators_identities_for_what_their_role_allows(
        tmp_path: Path, project: Path) -> None:
    store = OperatorStore.new(store_path(project))
    store = store.with_user("olga", Role.OBSERVER, password="olga-secret-1")
    store = store.with_user("otto", Role.OPERATOR, token="mrss_" + "t" * 43)
    store.save()
    service = configured_token({}, project)  # the project's own clients' identity
    assert service == store.service_token
    world = WorldModel(WorldModelStore(), RuleEngine([]), lambda _text: None)
    server = WorldModelHttp(world, token=service, operators=OperatorGuard(project, LOG))
    server.start()
    try:
        olga = mint(store, Identity("olga", Role.OBSERVER))
        assert request(server, "GET", "/objects", headers=bearer(olga))[0] == 200
        status, _, body = request(server, "POST", "/objects", HOTSPOT, bearer(olga))
        assert status == 403 and "the observer role may not send world_write" in \
            body["error"]
        assert request(server, "POST", "/objects", HOTSPOT, bearer("mrss_" + "t" * 43)
                       )[0] in (200, 201)
        assert request(server, "GET", "/objects")[0] == 401
        assert request(server, "GET", "/objects", headers=bearer("mrss_" + "x" * 43))[0] \
            == 401
        assert request(server, "GET", "/objects/h1", headers=bearer(service))[0] == 200
        assert json.loads(json.dumps(server.rejections.stats()))  # the refusals counted
    finally:
        server.stop()


def test_the_operators_credential_travels_in_the_envelope_and_never_into_a_recording(
        tmp_path: Path) -> None:
    from mrss.messages import Command, decode, encode
    from mrss.recording.format import RecordedMessage
    from mrss.recording.mcap_reader import McapRecording
    from mrss.recording.mcap_writer import McapRecordingWriter

    topic, payload = encode(Command("stop", target="p"), src="tui", op="s1:alice:1:2:3")
    env = decode(topic, payload)
    assert env.op == "s1:alice:1:2:3" and env.inc == 0
    assert decode(*encode(Command("stop", target="p"), src="tui")).op == ""
    with (tmp_path / "r.mcap").open("wb") as out:
        writer = McapRecordingWriter(out, created=time.time())
        writer.write(RecordedMessage(time.time(), (topic, payload)))
        writer.finish()
    with (tmp_path / "r.mcap").open("rb") as source:
        (entry,) = list(McapRecording(source).entries())
    assert entry.value()["src"] == "tui" and "op" not in entry.value()
    assert b"s1:alice" not in entry.data
