"""`mrss bench security`: what MAVLink signing and the world model's token cost.

MAVLink: one GLOBAL_POSITION_INT packed (signed: also signed) and parsed by a fresh
per-datagram decoder (signed: also checked), as the link does for every UDP datagram,
in this process. World model: GET /objects over one keep-alive loopback connection,
without and with a bearer token.
"""

from __future__ import annotations

import http.client
import secrets
import statistics
import time

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from mrss.actors.worldmodel.http import WorldModelHttp
from mrss.actors.worldmodel.model import WorldModel
from mrss.actors.worldmodel.rules import RuleEngine
from mrss.actors.worldmodel.store import WorldModelStore
from mrss.bench.report import BenchReport
from mrss.links.mavlink_signing import Signing, SigningParser


def _mavlink(signed: bool, n: int) -> tuple[float, float, int]:
    """(µs per pack, µs per parse, messages accepted) of n messages."""
    key = secrets.token_bytes(32)
    sender = SigningParser(None, srcSystem=1, srcComponent=1)
    receiver = Signing(key, link_id=0, name="bench receiver") if signed else None
    if signed:
        Signing(key, link_id=1, name="bench sender").attach(sender)
    msg = sender.global_position_int_encode(1, -353632620, 1491652370, 584000, 0, 0, 0, 0, 0)
    start = time.perf_counter()
    packets = [bytes(msg.pack(sender)) for _ in range(n)]
    packed = time.perf_counter()
    accepted = 0
    for packet in packets:
        if receiver is not None:
            parser = receiver.parser()
        else:
            parser = mavlink2.MAVLink(None)
            parser.robust_parsing = True
        for got in parser.parse_buffer(bytearray(packet)) or []:
            if got.get_type() != "BAD_DATA" and (receiver is None
                                                 or receiver.accepts(got, parser)):
                accepted += 1
    parsed = time.perf_counter()
    return (packed - start) / n * 1e6, (parsed - packed) / n * 1e6, accepted


def _http(token: str | None, n: int) -> list[float]:
    """Milliseconds per GET /objects over one keep-alive connection."""
    world = WorldModel(WorldModelStore(), RuleEngine([]), lambda _text: None)
    server = WorldModelHttp(world, token=token)
    server.start()
    host, port = server.url.removeprefix("http://").rsplit(":", 1)
    conn = http.client.HTTPConnection(host, int(port), timeout=10)
    headers = {"Authorization": f"Bearer {token}"} if token else {}
    samples = []
    try:
        for _ in range(n):
            t0 = time.perf_counter()
            conn.request("GET", "/objects", headers=headers)
            resp = conn.getresponse()
            resp.read()
            if resp.status != 200:
                raise RuntimeError(f"GET /objects answered {resp.status}")
            samples.append((time.perf_counter() - t0) * 1000)
    finally:
        conn.close()
        server.stop()
    return samples


def _p(samples: list[float], q: float) -> float:
    ordered = sorted(samples)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))]


def run(quick: bool) -> BenchReport:
    """Measure signing and token costs; `quick` uses small counts."""
    n_msgs, n_http = (2000, 200) if quick else (50000, 3000)
    report = BenchReport("security", ["what", "n", "median", "p95", "unit"], quick=quick)
    rows: dict[bool, tuple[float, float, int]] = {}
    for signed in (False, True):
        rows[signed] = _mavlink(signed, n_msgs)
        pack, parse, accepted = rows[signed]
        label = "signed" if signed else "unsigned"
        report.add_row(f"MAVLink pack, {label}", n_msgs, round(pack, 2), "", "µs/msg")
        report.add_row(f"MAVLink parse + check, {label}", n_msgs, round(parse, 2), "",
                       "µs/msg")
        report.check(f"every {label} message accepted", accepted == n_msgs)
    for token in (None, secrets.token_urlsafe(32)):
        samples = _http(token, n_http)
        report.add_row(f"world model GET /objects, {'token' if token else 'no token'}",
                       n_http, round(statistics.median(samples), 3),
                       round(_p(samples, 0.95), 3), "ms")
    report.notes.append(
        f"signing adds {rows[True][0] - rows[False][0]:.2f} µs to a send and "
        f"{rows[True][1] - rows[False][1]:.2f} µs to a receive per message")
    return report
