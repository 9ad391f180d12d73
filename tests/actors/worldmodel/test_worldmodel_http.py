"""The world model's HTTP API: round trips, rules firing on POST, clear 4xx errors."""

from __future__ import annotations

import http.client
import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from mrss.actors.worldmodel.http import WorldModelHttp
from mrss.actors.worldmodel.model import WorldModel
from mrss.actors.worldmodel.rules import NoObjectWithin, RuleEngine
from mrss.actors.worldmodel.store import WorldModelStore
from mrss.edge.retry import Attempt, classify
from mrss.world.access import (
    HttpWorldModel,
    WorldModelClient,
    WorldModelRejected,
    WorldModelUnavailable,
)


class Served:
    def __init__(self, world: WorldModel, http: WorldModelHttp, emitted: list[str]) -> None:
        self.world = world
        self.http = http
        self.emitted = emitted
        host, port = http.url.removeprefix("http://").split(":")
        self.host, self.port = host, int(port)

    def request(self, method: str, path: str, body: bytes | None = None,
                headers: dict[str, str] | None = None) -> tuple[int, Any]:
        conn = http.client.HTTPConnection(self.host, self.port, timeout=5)
        try:
            conn.request(method, path, body=body, headers=headers or {})
            resp = conn.getresponse()
            return resp.status, json.loads(resp.read())
        finally:
            conn.close()


@pytest.fixture()
def served() -> Iterator[Served]:
    emitted: list[str] = []
    world = WorldModel(WorldModelStore(), RuleEngine(
        [NoObjectWithin("hotspot", "water_source", 500, "hotspot_detected")]), emitted.append)
    server = WorldModelHttp(world)
    server.start()
    try:
        yield Served(world, server, emitted)
    finally:
        server.stop()


def post(s: Served, obj: Any) -> tuple[int, Any]:
    return s.request("POST", "/objects", json.dumps(obj).encode(),
                     {"Content-Type": "application/json"})


def test_listens_on_loopback_only(served: Served) -> None:
    assert served.host == "127.0.0.1"


def test_create_get_list_update_round_trip(served: Served) -> None:
    status, body = post(served, {"id": "h1", "kind": "hotspot",
                                 "position": {"lat": 43.6, "lon": 1.44},
                                 "attributes": {"intensity": 3}})
    assert status == 201 and body["op"] == "insert" and body["object"]["version"] == 1
    assert served.emitted == ["hotspot_detected(h1,43.6,1.44)"]
    status, body = served.request("GET", "/objects/h1")
    assert status == 200 and body["position"] == {"lat": 43.6, "lon": 1.44, "alt": 0.0}
    status, body = post(served, {"id": "h1", "kind": "hotspot", "attributes": {"seen": True}})
    assert status == 200 and body["op"] == "update"
    assert body["object"]["attributes"] == {"intensity": 3, "seen": True}
    post(served, {"id": "b1", "kind": "base", "position": {"lat": 43.601, "lon": 1.44}})
    status, body = served.request("GET", "/objects?kind=hotspot")
    assert status == 200 and [o["id"] for o in body["objects"]] == ["h1"]
    status, body = served.request("GET", "/objects")
    assert [o["id"] for o in body["objects"]] == ["b1", "h1"]
    status, body = served.request("GET", "/objects?lat=43.6&lon=1.44&radius_m=50")
    assert [o["id"] for o in body["objects"]] == ["h1"]
    assert served.world.get("b1") is not None  # same store as the bus uses


def test_ids_with_reserved_url_characters_round_trip(served: Served) -> None:
    status, _ = post(served, {"id": "zone A?#", "kind": "zone"})
    assert status == 201
    status, body = served.request("GET", "/objects/zone%20A%3F%23")
    assert status == 200 and body["id"] == "zone A?#"


@pytest.mark.parametrize(("method", "path", "body", "status", "reason"), [
    ("GET", "/objects/nope", None, 404, "no object"),
    ("GET", "/robots", None, 404, "no such path"),
    ("GET", "/objects/a/b", None, 404, "no such path"),
    ("POST", "/objects", b"{not json", 400, "not JSON"),
    ("POST", "/objects", b"\xff\xfe", 400, "not UTF-8"),
    ("POST", "/objects", b'{"id": "x"}', 400, "missing 'kind'"),
    ("POST", "/objects", b'{"id": "x", "kind": "r", "position": {"lat": 1e9, "lon": 0}}',
     400, "outside"),
    ("POST", "/objects", b'{"id": "x", "kind": "r", "attributes": {"v": NaN}}', 400,
     "not JSON"),
    ("POST", "/objects", b"[]", 400, "JSON object"),
    ("GET", "/objects?colour=red", None, 400, "unknown query"),
    ("GET", "/objects?kind=a&kind=b", None, 400, "at most once"),
    ("GET", "/objects?lat=1&lon=2", None, 400, "go together"),
    ("GET", "/objects?lat=x&lon=2&radius_m=3", None, 400, "bad position"),
    ("GET", "/objects?lat=1&lon=2&radius_m=-3", None, 400, "non-negative"),
    ("DELETE", "/objects/x", None, 405, "not allowed"),
    ("PUT", "/objects", b"{}", 405, "not allowed"),
])
def test_bad_requests_get_clear_errors(served: Served, method: str, path: str,
                                       body: bytes | None, status: int, reason: str) -> None:
    got_status, got = served.request(method, path, body)
    assert got_status == status
    assert reason in got["error"]


def test_missing_or_huge_content_length(served: Served) -> None:
    conn = http.client.HTTPConnection(served.host, served.port, timeout=5)
    try:
        conn.putrequest("POST", "/objects")
        conn.endheaders()
        resp = conn.getresponse()
        assert resp.status == 411
        resp.read()
    finally:
        conn.close()
    status, body = served.request("POST", "/objects", b"{}",
                                  {"Content-Length": str(10**9)})
    assert status == 413 and "at most" in body["error"]


def test_server_keeps_serving_after_bad_requests(served: Served) -> None:
    for _ in range(3):
        served.request("POST", "/objects", b"garbage")
    status, _ = post(served, {"id": "ok", "kind": "base"})
    assert status == 201


def test_http_world_model_client_speaks_the_api(served: Served) -> None:
    client = HttpWorldModel(served.http.url)
    assert client.upsert({"id": "w1", "kind": "water_source",
                          "position": {"lat": 10, "lon": 10}})["op"] == "insert"
    got = client.get("w1")
    assert got is not None and got["kind"] == "water_source"
    assert client.get("missing") is None
    assert [o["id"] for o in client.objects("water_source")] == ["w1"]
    assert client.near(10.001, 10, 200)[0]["id"] == "w1"
    with pytest.raises(WorldModelRejected, match="400") as rejected:
        client.upsert({"id": "bad"})
    assert classify(rejected.value) is Attempt.BAD_INPUT  # a bad object: not retried
    with pytest.raises(WorldModelUnavailable) as down:
        HttpWorldModel("http://127.0.0.1:1", timeout=1).get("x")
    assert classify(down.value) is Attempt.UNAVAILABLE  # nobody there: retried


def test_world_model_client_looks_the_url_up_for_every_call(served: Served,
                                                            tmp_path: Path) -> None:
    client = WorldModelClient(run_dir=tmp_path, timeout=2)
    with pytest.raises(WorldModelUnavailable, match="not up"):
        client.get("w1")  # no worldmodel.url yet: not up, so worth a retry
    (tmp_path / "worldmodel.url").write_text("http://127.0.0.1:1\n")
    with pytest.raises(WorldModelUnavailable):
        client.get("w1")  # a dead address
    (tmp_path / "worldmodel.url").write_text(served.http.url + "\n")
    assert client.upsert({"id": "w1", "kind": "base"})["op"] == "insert"  # same client
