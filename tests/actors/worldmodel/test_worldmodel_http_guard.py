"""The world model's HTTP API is safe to expose: a bearer token, JSON for every error the
HTTP layer raises before dispatch, and a per-connection timeout (real sockets)."""

from __future__ import annotations

import http.client
import json
import logging
import socket
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mrss.actors.worldmodel.http import WorldModelHttp
from mrss.actors.worldmodel.model import WorldModel
from mrss.actors.worldmodel.rules import RuleEngine
from mrss.actors.worldmodel.store import WorldModelStore
from mrss.api import world_model_token
from mrss.edge.http_token import configured_token, exposure_problem, is_loopback
from mrss.errors import ConfigError
from mrss.testing import wait_until
from mrss.world.access import HttpWorldModel, WorldModelClient, WorldModelRejected

TOKEN = "s3cret-token-0123456789abcdef"
HOTSPOT = {"id": "h1", "kind": "hotspot", "position": {"lat": -35.0, "lon": 149.0}}


def serve(token: str | None = None, timeout: float = 30.0) -> WorldModelHttp:
    world = WorldModel(WorldModelStore(), RuleEngine([]), lambda _text: None)
    server = WorldModelHttp(world, token=token, timeout=timeout)
    server.start()
    return server


@pytest.fixture()
def guarded() -> Iterator[WorldModelHttp]:
    server = serve(TOKEN)
    try:
        yield server
    finally:
        server.stop()


def address(server: WorldModelHttp) -> tuple[str, int]:
    host, port = server.url.removeprefix("http://").rsplit(":", 1)
    return host, int(port)


def request(server: WorldModelHttp, method: str, path: str, body: Any = None,
            headers: dict[str, str] | None = None) -> tuple[int, dict[str, str], Any]:
    conn = http.client.HTTPConnection(*address(server), timeout=10)
    try:
        data = None if body is None else json.dumps(body).encode()
        conn.request(method, path, body=data, headers=headers or {})
        resp = conn.getresponse()
        return resp.status, {k.lower(): v for k, v in resp.getheaders()}, json.loads(resp.read())
    finally:
        conn.close()


def raw(server: WorldModelHttp, data: bytes) -> tuple[int, dict[str, str], Any]:
    """Send raw bytes; parse the one answer (status line, headers, JSON body)."""
    with socket.create_connection(address(server), timeout=10) as sock:
        sock.sendall(data)
        received = b""
        while True:
            chunk = sock.recv(65536)
            if not chunk:
                break
            received += chunk
    head, _, body = received.partition(b"\r\n\r\n")
    lines = head.decode("latin-1").split("\r\n")
    version, status, _ = lines[0].split(" ", 2)
    assert version == "HTTP/1.1", lines[0]
    headers = {k.strip().lower(): v.strip() for k, v in
               (line.split(":", 1) for line in lines[1:])}
    assert headers["content-type"] == "application/json"
    assert int(headers["content-length"]) == len(body)
    return int(status), headers, json.loads(body)


def bearer(token: str) -> dict[str, str]:
    return {"Authorization": f"Bearer {token}"}


def test_every_request_needs_the_token(guarded: WorldModelHttp) -> None:
    for headers in ({}, bearer("wrong-token-0123456789"), {"Authorization": TOKEN},
                    {"Authorization": f"Basic {TOKEN}"}):
        status, head, body = request(guarded, "GET", "/objects", headers=headers)
        assert status == 401 and "Authorization: Bearer" in body["error"], headers
        assert head["www-authenticate"].startswith("Bearer")
    status, _, body = request(guarded, "POST", "/objects", HOTSPOT)
    assert status == 401
    status, _, body = request(guarded, "GET", "/objects/h1", headers=bearer(TOKEN))
    assert status == 404                                   # nothing was stored
    status, _, body = request(guarded, "POST", "/objects", HOTSPOT, bearer(TOKEN))
    assert status == 201 and body["object"]["id"] == "h1"
    status, _, body = request(guarded, "GET", "/objects", headers=bearer(TOKEN.lower()
                                                                          .upper()))
    assert status == 401                                   # case matters


def test_a_refused_post_body_is_never_read_as_the_next_request(
        guarded: WorldModelHttp) -> None:
    smuggled = b"GET /objects HTTP/1.1\r\nHost: x\r\n\r\n"
    status, head, _ = raw(guarded, b"POST /objects HTTP/1.1\r\nHost: x\r\nContent-Length: "
                          + str(len(smuggled)).encode() + b"\r\n\r\n" + smuggled)
    assert status == 401 and head["connection"] == "close"  # raw() read to the end: one answer


def test_expect_100_continue_without_the_token_is_refused_before_the_body(
        guarded: WorldModelHttp) -> None:
    status, head, body = raw(guarded, b"POST /objects HTTP/1.1\r\nContent-Length: 20\r\n"
                             b"Expect: 100-continue\r\n\r\n")
    assert status == 401 and head["connection"] == "close"   # no "100 Continue" first
    assert "Authorization: Bearer" in body["error"]


def test_the_clients_send_the_token(guarded: WorldModelHttp, tmp_path: Path) -> None:
    client = HttpWorldModel(guarded.url, token=TOKEN)
    assert client.upsert(HOTSPOT)["op"] == "insert"
    (tmp_path / "worldmodel.url").write_text(guarded.url + "\n")
    run_client = WorldModelClient(run_dir=tmp_path, token=TOKEN)
    assert run_client.get("h1") is not None
    assert [o["id"] for o in run_client.near(-35.0, 149.0, 10)] == ["h1"]
    with pytest.raises(WorldModelRejected, match="HTTP 401: missing or wrong token"):
        WorldModelClient(run_dir=tmp_path).objects()


@pytest.mark.parametrize(("data", "status", "says"), [
    (b"BREW /objects HTTP/1.1\r\nHost: x\r\n\r\n", 501, "unsupported method 'BREW'"),
    (b"GET /" + b"a" * 70000 + b" HTTP/1.1\r\n\r\n", 414, "request line over"),
    (b"GET /objects HTTP/1.1\r\nX-Big: " + b"b" * 70000 + b"\r\n\r\n", 431, "Line too long"),
    (b"GET /objects HTTP/1.1\r\n" + b"".join(b"X-%d: 1\r\n" % i for i in range(120))
     + b"\r\n", 431, "Too many headers"),
    (b"GET /objects HTTP/x.y\r\n\r\n", 400, "Bad request version"),
    (b"GET /objects HTTP/2.0\r\n\r\n", 505, "Invalid HTTP version"),
    (b"GET /objects\r\n\r\n", 400, "request line must be METHOD PATH HTTP/1.x"),
    (b"what is this request\r\n\r\n", 400, "Bad request"),
])
def test_errors_before_dispatch_are_json_with_a_status_line(
        guarded: WorldModelHttp, data: bytes, status: int, says: str) -> None:
    got, head, body = raw(guarded, data)
    assert got == status and says in body["error"], body
    assert set(body) == {"error"}
    assert head["connection"] == "close"


@pytest.mark.parametrize(("data", "status", "says"), [
    (b"Content-Length: 5\r\n\r\n{nope", 400, "body is not JSON"),
    (b"Content-Length: x\r\n\r\n", 400, "bad Content-Length"),
    (b"Content-Length: 99999999\r\n\r\n", 413, "body must be at most"),
    (b"\r\n", 411, "Content-Length required"),
])
def test_bad_bodies_are_json_errors(guarded: WorldModelHttp, data: bytes, status: int,
                                    says: str) -> None:
    got, _, body = raw(guarded, b"POST /objects HTTP/1.1\r\nConnection: close\r\n"
                       b"Authorization: Bearer " + TOKEN.encode() + b"\r\n" + data)
    assert got == status and says in body["error"], body


def test_a_chunked_body_is_refused_and_never_read_as_a_request(
        guarded: WorldModelHttp) -> None:
    smuggled = b"GET /objects HTTP/1.1\r\nHost: x\r\n\r\n"
    status, head, body = raw(guarded, b"POST /objects HTTP/1.1\r\nAuthorization: Bearer "
                             + TOKEN.encode() + b"\r\nTransfer-Encoding: chunked\r\n\r\n"
                             + b"%x\r\n" % len(smuggled) + smuggled + b"\r\n0\r\n\r\n")
    assert status == 411 and head["connection"] == "close"   # one answer, then closed


def test_a_stalled_client_does_not_delay_another(guarded: WorldModelHttp) -> None:
    with socket.create_connection(address(guarded), timeout=10) as stalled:
        stalled.sendall(b"GET /objects HTTP/1.1\r\nHost: x\r\nAuthoriz")  # ... and stops
        for _ in range(3):
            status, _, body = request(guarded, "GET", "/objects", headers=bearer(TOKEN))
            assert status == 200 and body == {"objects": []}
        stalled.setblocking(False)
        with pytest.raises(BlockingIOError):
            stalled.recv(1)                       # still waiting for the rest: no answer


def test_a_stalled_client_is_answered_408_and_dropped_after_the_timeout() -> None:
    server = serve(TOKEN, timeout=2.0)  # the request after it comes whole within 2 s
    try:
        with socket.create_connection(address(server), timeout=30) as stalled:
            stalled.sendall(b"POST /objects HTTP/1.1\r\nAuthorization: Bearer "
                            + TOKEN.encode() + b"\r\nContent-Length: 100\r\n\r\n{\"id\"")
            received = b""
            while chunk := stalled.recv(4096):     # the server closes the connection
                received += chunk
        assert received.startswith(b"HTTP/1.1 408 ")
        body = json.loads(received.partition(b"\r\n\r\n")[2])
        assert "no complete request within 2 s" in body["error"]
        status, _, _ = request(server, "GET", "/objects", headers=bearer(TOKEN))
        assert status == 200                      # and it keeps serving
    finally:
        server.stop()


def test_keep_alive_connections_still_serve_several_requests(guarded: WorldModelHttp) -> None:
    conn = http.client.HTTPConnection(*address(guarded), timeout=10)
    try:
        for _ in range(3):
            conn.request("GET", "/objects", headers=bearer(TOKEN))
            resp = conn.getresponse()
            assert resp.status == 200 and resp.getheader("Connection") != "close"
            resp.read()
    finally:
        conn.close()


def test_token_configuration_and_exposure_rules(tmp_path: Path,
                                                monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "wm.token").write_text(TOKEN + "\n")
    assert configured_token({"token_file": "wm.token"}, tmp_path) == TOKEN
    monkeypatch.setenv("WM_TOKEN", TOKEN)
    assert configured_token({"token_env": "WM_TOKEN"}, tmp_path) == TOKEN
    assert configured_token({}, tmp_path) is None
    assert world_model_token(tmp_path) is None                       # no project.toml
    (tmp_path / "project.toml").write_text('[worldmodel]\ntoken_file = "wm.token"\n')
    assert world_model_token(tmp_path) == TOKEN                      # mrss.api's helper
    for section, key, says in [
        ({"token_file": "none.token"}, "worldmodel.token_file", "cannot read token file"),
        ({"token_env": "NO_SUCH_VAR_XYZ"}, "worldmodel.token_env", "is not set"),
        ({"token_file": "wm.token", "token_env": "WM_TOKEN"}, "worldmodel.token_env",
         "not both"),
    ]:
        with pytest.raises(ConfigError, match=says) as info:
            configured_token(section, tmp_path)
        assert info.value.key == key
    (tmp_path / "short.token").write_text("abc")
    with pytest.raises(ConfigError, match="16 to 512 characters"):
        configured_token({"token_file": "short.token"}, tmp_path)
    assert all(is_loopback(h) for h in ("127.0.0.1", "127.1.2.3", "::1", "localhost"))
    assert not any(is_loopback(h) for h in ("0.0.0.0", "::", "10.0.0.7", "example.org"))
    assert exposure_problem("0.0.0.0", False) is not None
    assert "token_file" in (exposure_problem("10.0.0.7", False) or "")
    assert exposure_problem("0.0.0.0", True) is None
    assert exposure_problem("127.0.0.1", False) is None


def test_a_server_without_a_token_answers_everyone_on_loopback() -> None:
    server = serve(None)
    try:
        assert server.url.startswith("http://127.0.0.1:") and not server.token_required
        status, _, _ = request(server, "GET", "/objects")
        assert status == 200
        status, _, body = raw(server, b"DELETE /objects HTTP/1.1\r\nConnection: close\r\n\r\n")
        assert status == 405 and "DELETE not allowed" in body["error"]
    finally:
        server.stop()


def test_a_slow_client_waits_alone(guarded: WorldModelHttp) -> None:
    """Many stalled connections do not starve a well-behaved client either."""
    stalled = [socket.create_connection(address(guarded), timeout=10) for _ in range(20)]
    try:
        for sock in stalled:
            sock.sendall(b"GET /obj")
        status, _, _ = request(guarded, "GET", "/objects", headers=bearer(TOKEN))
        assert status == 200
    finally:
        for sock in stalled:
            sock.close()
    wait_until(lambda: request(guarded, "GET", "/objects", headers=bearer(TOKEN))[0] == 200,
               timeout=10, message="serving after the stalled clients left")


@pytest.fixture(scope="module")
def shared() -> Iterator[WorldModelHttp]:
    server = serve(TOKEN, timeout=2.0)
    try:
        yield server
    finally:
        server.stop()


@settings(max_examples=80, deadline=None)
@given(line=st.binary(max_size=120), headers=st.lists(st.binary(max_size=60), max_size=5))
def test_any_bytes_get_a_json_answer_or_a_closed_connection(
        shared: WorldModelHttp, line: bytes, headers: list[bytes]) -> None:
    data = line + b"\r\n" + b"".join(h.replace(b"\n", b"") + b"\r\n" for h in headers) \
        + b"Connection: close\r\n\r\n"
    with socket.create_connection(address(shared), timeout=10) as sock:
        sock.sendall(data)
        received = b""
        while chunk := sock.recv(65536):
            received += chunk
    if received:
        head, _, body = received.partition(b"\r\n\r\n")
        assert head.startswith(b"HTTP/1.1 "), received[:200]
        assert b"content-type: application/json" in head.lower()
        answer = json.loads(body)
        assert isinstance(answer, dict) and set(answer) == {"error"}
    status, _, _ = request(shared, "GET", "/objects", headers=bearer(TOKEN))
    assert status == 200


def test_refused_requests_are_counted_and_logged_once_per_client_and_status(
        guarded: WorldModelHttp, caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.INFO, logger="mrss.worldmodel.http")
    for _ in range(30):
        assert request(guarded, "GET", "/objects")[0] == 401
    for _ in range(5):
        assert request(guarded, "POST", "/objects", {"id": "h1", "kind": "hotspot",
                                                     "position": {"lat": 95.0, "lon": 1.0}},
                       headers=bearer(TOKEN))[0] == 400
    assert request(guarded, "GET", "/objects/nobody", headers=bearer(TOKEN))[0] == 404
    assert guarded.rejections.stats() == {"127.0.0.1: 401 Unauthorized": 30,
                                          "127.0.0.1: 400 Bad Request": 5}
    lines = [r.getMessage() for r in caplog.records if "refused HTTP request" in r.getMessage()]
    assert len(lines) == 2, lines
    assert "refused HTTP request from 127.0.0.1: 401 Unauthorized (GET /objects without a " \
        "valid token)" in lines[0]
    assert "95" in lines[1]  # the detail names what was wrong


AUTH = b"Authorization: Bearer " + TOKEN.encode() + b"\r\n"
BODY = json.dumps(HOTSPOT).encode()


@pytest.mark.parametrize(("data", "says"), [
    # HTTP/0.9: no version and no headers; its client waits for the answer (the server
    # must not wait for headers until the connection times out)
    (b"GET /objects\r\n", "request line must be METHOD PATH HTTP/1.x"),
    (b"GET /objects HTTP/0.9\r\n\r\n", "Bad request version 'HTTP/0.9'"),
    (b"GET /objects HTTP/01.1\r\n\r\n", "Bad request version 'HTTP/01.1'"),
    # RFC 9112 6.3: a body's length must be one run of digits, or the request is refused
    (b"POST /objects HTTP/1.1\r\n" + AUTH + b"Content-Length: %d\r\nContent-Length: 5\r\n\r\n"
     % len(BODY) + BODY, "conflicting Content-Length values"),
    (b"POST /objects HTTP/1.1\r\n" + AUTH + b"Content-Length: %d, 5\r\n\r\n" % len(BODY)
     + BODY, "conflicting Content-Length values"),
    (b"GET /objects HTTP/1.1\r\n" + AUTH + b"Content-Length: 0\r\nContent-Length: 40\r\n\r\n",
     "conflicting Content-Length values"),
    (b"POST /objects HTTP/1.1\r\n" + AUTH + b"Content-Length: +%d\r\n\r\n" % len(BODY) + BODY,
     "bad Content-Length '+"),
    (b"POST /objects HTTP/1.1\r\n" + AUTH + b"Content-Length: 6_9\r\n\r\n" + BODY,
     "bad Content-Length '6_9'"),
    (b"POST /objects HTTP/1.1\r\n" + AUTH + b"Content-Length: %d\r\nTransfer-Encoding: "
     b"chunked\r\n\r\n" % len(BODY) + BODY, "Content-Length and Transfer-Encoding"),
])
def test_ambiguous_requests_are_refused_400_and_closed(guarded: WorldModelHttp, data: bytes,
                                                       says: str) -> None:
    status, head, body = raw(guarded, data)
    assert status == 400 and says in body["error"], body
    assert head["connection"] == "close"            # raw() read to the end: one answer
    assert guarded.rejections.stats() == {"127.0.0.1: 400 Bad Request": 1}
    assert request(guarded, "GET", "/objects/h1", headers=bearer(TOKEN))[0] == 404  # unstored


def test_a_repeated_equal_content_length_is_one_length(guarded: WorldModelHttp) -> None:
    status, _, body = raw(guarded, b"POST /objects HTTP/1.1\r\nConnection: close\r\n" + AUTH
                          + b"Content-Length: %d\r\nContent-Length: %d\r\n\r\n"
                          % (len(BODY), len(BODY)) + BODY)
    assert status == 201 and body["object"]["id"] == "h1"


@pytest.mark.parametrize("body", [
    b'{"id": "h\\ud800", "kind": "hotspot"}',
    b'{"id": "h1", "kind": "hotspot", "attributes": {"\\udc00": 1}}',
])
def test_a_lone_surrogate_in_a_body_is_a_bad_body(guarded: WorldModelHttp,
                                                  body: bytes) -> None:
    status, _, answer = raw(guarded, b"POST /objects HTTP/1.1\r\nConnection: close\r\n" + AUTH
                            + b"Content-Length: %d\r\n\r\n" % len(body) + body)
    assert status == 400 and "not Unicode text: a lone surrogate" in answer["error"], answer
    assert request(guarded, "GET", "/objects", headers=bearer(TOKEN))[2] == {"objects": []}
