"""The HTTP robot link against a hostile robot (a real HTTP server on loopback, seeded):
junk, out-of-range and other robots' telemetry and junk command answers are refused
and counted, never become telemetry, never raise anything but a LinkError, never log a
traceback; the good samples among them still get through."""

from __future__ import annotations

import json
import logging
import random
import threading
from collections.abc import Iterator
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any

import pytest

from mrss.links.errors import LinkError
from mrss.links.factory import create_link
from mrss.links.http import HttpLink
from mrss.testing import wait_until

SEED = 1517
FORGED_LAT = 95.0
GOOD = {"id": "bot1", "lat": 48.2, "lon": 16.3, "heading": 10.0, "speed": 1.0,
        "battery": 80.0, "mode": "idle"}


def hostile_telemetry(rng: random.Random, n: int) -> bytes:
    """One answer to GET /telemetry: every fourth a good sample (lat marks its number)."""
    if n % 4 == 0:
        return json.dumps(dict(GOOD, lat=40.0 + n * 1e-4)).encode()
    return rng.choice([
        bytes(rng.randrange(256) for _ in range(rng.randrange(60))),
        json.dumps(dict(GOOD, lat=FORGED_LAT)).encode(),
        json.dumps(dict(GOOD, battery=-5.0)).encode(),
        json.dumps(dict(GOOD, speed=500.0)).encode(),  # the protocol's bound, not a UGV's
        json.dumps(dict(GOOD, id="bot2", lat=41.0)).encode(),
        json.dumps(dict(GOOD, lat=10 ** 400)).encode(),
        b'{"id": "bot1", "lat": NaN, "lon": 1}',
        json.dumps(dict(GOOD, mode="x" * 10_000)).encode(),
        b"[" * 5000 + b"]" * 5000,
        json.dumps([GOOD]).encode(),
    ])


class HostileRobot:
    """Serves the seeded answers in turn; counts what it served."""

    def __init__(self, rng: random.Random) -> None:
        self.rng = rng
        self.served = 0
        self.lock = threading.Lock()
        robot = self

        class Handler(BaseHTTPRequestHandler):
            def log_message(self, format: str, *args: Any) -> None:  # noqa: A002
                pass

            def _send(self, body: bytes, status: int = 200) -> None:
                self.send_response(status)
                self.send_header("Content-Length", str(len(body)))
                self.end_headers()
                self.wfile.write(body)

            def do_GET(self) -> None:  # noqa: N802
                with robot.lock:
                    body = hostile_telemetry(robot.rng, robot.served)
                    robot.served += 1
                self._send(body)

            def do_POST(self) -> None:  # noqa: N802
                self.rfile.read(int(self.headers.get("Content-Length", "0")))
                with robot.lock:
                    body = robot.rng.choice([b"junk", b"{}", b'{"id": "other", '
                                             b'"status": "done"}', b"[1]"])
                self._send(body, robot.rng.choice([200, 200, 500]))

        self.server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.thread = threading.Thread(target=self.server.serve_forever, args=(0.05,),
                                       daemon=True)

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.server.server_address[1]}"


@pytest.fixture()
def hostile() -> Iterator[HostileRobot]:
    robot = HostileRobot(random.Random(SEED))
    robot.thread.start()
    try:
        yield robot
    finally:
        robot.server.shutdown()
        robot.server.server_close()


def test_a_hostile_robot_never_feeds_the_link_bad_telemetry(
        hostile: HostileRobot, caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.DEBUG)
    records: list[dict[str, Any]] = []
    link = create_link("bot1", "http", {"url": hostile.url, "poll": 0.005, "timeout": 5.0,
                                        "command_timeout": 0.5, "retries": 1},
                       on_telemetry=records.append)
    assert isinstance(link, HttpLink)
    link.start()
    try:
        wait_until(lambda: hostile.served >= 120, timeout=60, message="120 answers served")
        for _ in range(3):  # junk answers to commands: refused or timed out, nothing else
            with pytest.raises(LinkError):
                link.goto(48.3, 16.4)
    finally:
        link.close()
    positions = [r for r in list(records) if r["type"] == "position"]
    assert positions and all(40.0 <= r["lat"] < 41.0 for r in positions), positions[:5]
    assert not [r for r in records if r["type"] == "battery" and r["remaining"] < 0]
    assert link.rejections.total >= hostile.served // 2  # most answers were bad
    assert any("out of range" in key for key in link.rejections.stats()), \
        link.rejections.stats()  # the robot type's limits, past the protocol's
    assert not [r for r in caplog.records if r.exc_info], "a traceback was logged"
