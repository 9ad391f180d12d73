"""Seeded hostile traffic for every edge of a running system (issue 15, "a fuzz test per
edge in a short seeded form"): bus frames, robot telemetry over MQTT and MAVLink, the
world model's HTTP API, percepts for the reasoner's parser, and a replayed recording.

Each sender returns how many of its messages a component must count as refused, so a
test can wait for the `Rejections` reports to reach them (everything was handled) before
it asserts what must not have happened. Every forged record is invalid by construction
(out of range, unknown robot, unsigned, a sender-set source, ...): none may become
telemetry, a percept, a world model object or a robot command. Forged hotspots carry ids
from `FORGED_IDS` and forged positions `FORGED_LAT`, to be looked for afterwards.
"""

from __future__ import annotations

import json
import random
import socket
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mrss.bus import BusEndpoints
from mrss.links.ardupilot import HOTSPOT_PREFIX
from mrss.links.mavconn import MAV, MavConnection
from mrss.links.mqtt_url import new_client, parse_broker_url
from mrss.links.ugv_protocol import UgvTopics
from mrss.messages import Heartbeat, Percept, RobotData, encode
from mrss.recording.format import RecordedMessage, RecordingWriter
from tests.bus.bus_helpers import RawPublisher

FORGED_IDS = range(900, 1000)  # hotspot ids of forged reports
FORGED_LAT = 95.0  # an impossible latitude
SRC = "fuzzer"
# Bus topics junk goes to: what components decode (never ctl.* or action.control, where
# a valid message would be an order, not data).
JUNK_TOPICS = ["percept", "robot.uav1.data", "robot.ugv1.data", "action.status", "dl.request",
               "sup.heartbeat.fuzz", "edge.report", "rel.action.x"]


def junk(rng: random.Random, n: int = 40) -> bytes:
    return bytes(rng.randrange(256) for _ in range(rng.randrange(n)))


# ------------------------------------------------------------------------ percepts, data
def bad_percept(rng: random.Random, n: int) -> str:
    """A percept text the reasoner must refuse (each kind is invalid by construction)."""
    hs = rng.choice(FORGED_IDS)
    return rng.choice([
        f"hotspot_detected(hs{hs}, -35.3604, 149.1657)[source(self)]",  # forged source
        f"hotspot_detected(hs{hs}, Lat, 149.1657)",  # not ground
        f"fz{n}(" + "f(" * 80 + "a" + ")" * 80 + ")",  # too deep
        f"fz{n}({rng.choice(['1e999', '9**9**9', '2^64', '-1e400'])})",  # no such number
        f"fz{n}({rng.randrange(2**60, 2**80)})",  # beyond +-2**53
        "(" + "".join(rng.choice("ab(),[]\"'X_ 1.") for _ in range(rng.randrange(30))),
    ])


def bad_record(rng: random.Random, n: int) -> RobotData:
    """Robot data the data layer must refuse."""
    hs = rng.choice(FORGED_IDS)
    return rng.choice([
        RobotData(robot="uav1", data={"type": "hotspot", "id": hs, "lat": FORGED_LAT,
                                      "lon": 149.1657, "temperature": 500.0}),
        RobotData(robot="uav1", data={"type": "hotspot", "id": hs, "lat": -35.3604,
                                      "lon": 149.1657, "temperature": 1e9}),
        RobotData(robot="uav1", data={"type": "position", "lat": -35.36, "lon": 149.16,
                                      "alt": 2.1e6}),
        RobotData(robot="ghost", data={"type": "hotspot", "id": hs, "lat": -35.3604,
                                       "lon": 149.1657}),
        RobotData(robot="ugv1", data={"type": "battery", "remaining": -5.0 - n}),
        RobotData(robot="ugv1", data={"type": "tank", "level": float("nan")}),
        RobotData(robot="ugv1", data={"type": "position", "lat": -35.36, "lon": 149.16,
                                      "robot": "uav1"}),
        RobotData(robot="ugv1", data={"type": "x", "v": nested(20)}),
        RobotData(robot="uav1", data={"type": "mission", "current": 2**40}),
    ])


def nested(depth: int) -> Any:
    value: Any = 1
    for _ in range(depth):
        value = [value]
    return value


# ------------------------------------------------------------------------------ the bus
@dataclass
class Sent:
    """What a sender expects to be refused, by component."""

    percepts: int = 0  # by the reasoner
    records: int = 0  # by the data layer


class RawBus:
    """Raw ZeroMQ sockets that reach every subscriber of the bus (the proxy's frontend;
    on a direct bus each member's socket too, each joined before anything is sent):
    any frames at all."""

    def __init__(self, endpoints: BusEndpoints) -> None:
        self.sock = RawPublisher(endpoints, linger_ms=1000).wait_joined(30)
        self._pids = iter(range(1, 10**9))  # across syncs: a probe is never taken for another's

    def send(self, frames: list[bytes]) -> None:
        self.sock.send_multipart(frames)

    def sync(self, seen: Any, timeout: float = 10.0) -> None:
        """Send heartbeats of "fuzz" until `seen(pid)` says one came back through the
        proxy: everything sent before it has passed the proxy."""
        from mrss.testing import wait_until

        sent: list[int] = []

        def probe() -> bool:
            # any probe of this sync that came back will do: the one just sent has had no
            # time to cross the proxy yet
            sent.append(next(self._pids))
            self.send(list(encode(Heartbeat(component="fuzz", pid=sent[-1]), src=SRC)))
            return any(seen(pid) for pid in sent)
        wait_until(probe, timeout, interval=0.05, message="the raw bus socket heard")

    def close(self) -> None:
        self.sock.close()


def fuzz_bus(bus: RawBus, rng: random.Random, rounds: int = 150) -> Sent:
    """Junk frames, damaged envelopes and hostile (well-encoded) percepts and records."""
    sent = Sent()
    for n in range(rounds):
        kind = rng.randrange(6)
        if kind == 0:
            frames = [rng.choice(JUNK_TOPICS).encode(), junk(rng)]
            frames = rng.choice([frames, frames[:1], [*frames, junk(rng)], [junk(rng)]])
        elif kind in (1, 2):  # a harmless envelope damaged: cut, or a byte flipped
            topic, payload = encode(rng.choice([
                Percept(literal=f"noise({n})"),
                RobotData(robot="ghost", data={"type": "battery", "remaining": 5.0})]),
                src=SRC)
            cut = rng.randrange(len(payload))
            payload = payload[:cut] if kind == 1 else (
                payload[:cut] + bytes([payload[cut] ^ (1 << rng.randrange(8))])
                + payload[cut + 1:])
            frames = [topic, payload]
        elif kind == 3:
            frames = list(encode(Percept(literal=bad_percept(rng, n)), src=SRC))
            sent.percepts += 1
        else:
            frames = list(encode(bad_record(rng, n), src=SRC))
            sent.records += 1
        bus.send(frames)
    return sent


# ------------------------------------------------------------------------------ MQTT
def mqtt_payloads(rng: random.Random, rounds: int) -> Iterator[tuple[str, bytes]]:
    """(which topic of ugv1, payload): junk and forged telemetry, junk acks and status."""
    good = {"id": "ugv1", "ts": 1.0, "lat": -35.3635, "lon": 149.165, "heading": 0.0,
            "speed": 0.0, "battery": 90.0, "tank": 10.0, "tank_capacity": 200.0,
            "pumping": False, "mode": "idle", "at_base": True, "teleop": False}
    for n in range(rounds):
        kind = rng.randrange(7)
        if kind == 0:
            yield "telemetry", junk(rng)
        elif kind == 1:
            yield "telemetry", json.dumps(dict(good, lat=FORGED_LAT)).encode()
        elif kind == 2:
            yield "telemetry", json.dumps(dict(good, battery=-3.0 - n)).encode()
        elif kind == 3:
            yield "telemetry", json.dumps(dict(good, speed=10 ** 400)).encode()
        elif kind == 4:
            yield "telemetry", json.dumps(dict(good, id="ugv2")).encode()
        elif kind == 5:
            yield "telemetry", json.dumps(dict(good, tank=float("nan"))).encode()
        else:
            yield rng.choice(["ack", "status"]), rng.choice([
                junk(rng), b"{}", b'{"id": 5}', json.dumps(nested(40)).encode()])


def fuzz_mqtt(broker_url: str, rng: random.Random, rounds: int = 60) -> tuple[int, int]:
    """Hostile messages on ugv1's topics and the operator's area topic, with the
    project's login (QoS 1, all acknowledged). Returns (to ugv1's link, to events)."""
    address = parse_broker_url(broker_url)
    client = new_client(f"fuzzer-{rng.randrange(10**6)}", address)
    client.connect(address.host, address.port, keepalive=10)
    client.loop_start()
    topics = UgvTopics.for_robot("ugv1")
    infos = []
    link = events = 0
    try:
        for which, payload in mqtt_payloads(rng, rounds):
            infos.append(client.publish(getattr(topics, which), payload, qos=1))
            link += 1
        for n in range(rounds // 3):
            payload = rng.choice([junk(rng), b"[1, 2]", b'{"goal": 5}',
                                  json.dumps({"goal": f"fz{n}", "priority": 2,
                                              "center": [FORGED_LAT, 149.0],
                                              "radius": 100}).encode(),
                                  json.dumps({"goal": f"fz{n}", "priority": 2,
                                              "center": [-35.36, 149.16],
                                              "radius": -1e308}).encode()])
            infos.append(client.publish("mrss/ui/area", payload, qos=1))
            events += 1
        for info in infos:
            info.wait_for_publish(timeout=10)
    finally:
        client.disconnect()  # first: a loop stopped first sits out its 1 s select
        client.loop_stop()
    return link, events


# --------------------------------------------------------------------------- MAVLink
def udp_ports(pid: int) -> list[int]:
    """The local UDP ports of a process (a link's socket among them)."""
    import psutil

    return sorted({c.laddr.port for c in psutil.Process(pid).net_connections(kind="udp4")
                   if c.laddr})


def fuzz_mavlink(ports: list[int], rng: random.Random, rounds: int = 20) -> tuple[int, int]:
    """Junk datagrams, and unsigned and wrongly signed STATUSTEXT hotspots and positions
    as the vehicle (system 1), to each port. Returns (unsigned, wrongly signed) sent."""
    unsigned = wrong = 0
    for port in ports:
        plain = MavConnection(f"udpout:127.0.0.1:{port}", source_system=1,
                              source_component=1)
        forged = MavConnection(f"udpout:127.0.0.1:{port}", source_system=1,
                               source_component=1, signing_key=rng.randbytes(32))
        raw = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            for n in range(rounds):
                conn = rng.choice([plain, forged])
                mav = conn.conn.mav
                text = f"{HOTSPOT_PREFIX} {FORGED_IDS[n % 100]} -35.3604000 149.1657000 500"
                conn.send(rng.choice([
                    mav.statustext_encode(MAV.MAV_SEVERITY_INFO, text.encode()),
                    mav.global_position_int_encode(0, int(-35.36e7), int(149.16e7),
                                                   2_100_000_000, 2_000_000_000, 0, 0, 0, 0)]))
                if conn is plain:
                    unsigned += 1
                else:
                    wrong += 1
                raw.sendto(junk(rng, 300), ("127.0.0.1", port))
        finally:
            plain.close()
            forged.close()
            raw.close()
    return unsigned, wrong


# ------------------------------------------------------------------------------ HTTP
def http_exchange(port: int, data: bytes) -> bytes:
    with socket.create_connection(("127.0.0.1", port), timeout=10) as sock:
        sock.sendall(data)
        received = b""
        while chunk := sock.recv(65536):
            received += chunk
    return received


def assert_json_answer(received: bytes) -> int:
    """The status of one JSON error or answer (0: the server closed without a word)."""
    if not received:
        return 0
    head, _, body = received.partition(b"\r\n\r\n")
    assert head.startswith(b"HTTP/1.1 "), received[:200]
    assert b"content-type: application/json" in head.lower(), head
    assert isinstance(json.loads(body), dict)
    return int(head.split(b" ", 2)[1])


def fuzz_http(port: int, token: str, rng: random.Random, rounds: int = 30) -> list[int]:
    """Junk requests, requests without or with a wrong token, and forged objects with the
    right token (out of range): every answer JSON, none a 2xx. Returns the statuses."""
    statuses = []
    forged = json.dumps({"id": f"hs{FORGED_IDS[0]}", "kind": "hotspot",
                         "position": {"lat": FORGED_LAT, "lon": 149.0}}).encode()
    for n in range(rounds):
        kind = rng.randrange(4)
        if kind == 0:
            data = junk(rng, 120) + b"\r\n" + junk(rng, 60).replace(b"\n", b"") \
                + b"\r\nConnection: close\r\n\r\n"
        elif kind == 1:
            auth = rng.choice([b"", b"Authorization: Bearer wrong\r\n",
                               b"Authorization: Basic " + junk(rng, 20).hex().encode()
                               + b"\r\n"])
            data = (b"GET /objects?kind=hotspot HTTP/1.1\r\nHost: x\r\n" + auth
                    + b"Connection: close\r\n\r\n")
        else:
            body = forged if kind == 2 else junk(rng, 80)
            data = (b"POST /objects HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer "
                    + token.encode() + b"\r\nContent-Type: application/json\r\n"
                    + b"Content-Length: " + str(len(body)).encode()
                    + b"\r\nConnection: close\r\n\r\n" + body)
        status = assert_json_answer(http_exchange(port, data))
        assert not 200 <= status < 300, (n, data[:200])
        statuses.append(status)
    return statuses


# ---------------------------------------------------------------------------- replay
def fuzz_replay(run_dir: Path, folder: Path, rng: random.Random, rounds: int = 40) -> Sent:
    """`mrss replay` of a recording of hostile percepts and records and junk frames into
    the running system's bus; the command itself ends cleanly."""
    sent = Sent()
    path = folder / "hostile.mrssrec"
    with path.open("wb") as f:
        writer = RecordingWriter(f, created=1.0)
        t = 1_700_000_000.0
        for n in range(rounds):
            t += rng.random() * 1e6  # implausible gaps: replay clamps them
            kind = rng.randrange(3)
            if kind == 0:
                frames = encode(Percept(literal=bad_percept(rng, n)), src="recorded")
                sent.percepts += 1
            elif kind == 1:
                frames = encode(bad_record(rng, n), src="recorded")
                sent.records += 1
            else:
                frames = (rng.choice(JUNK_TOPICS).encode(), junk(rng))
            writer.write(RecordedMessage(t, frames))
    out = subprocess.run([sys.executable, "-m", "mrss", "replay", str(path), "--run-dir",
                          str(run_dir), "--max-gap", "0.01"],
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert "Traceback" not in out.stderr + out.stdout
    return sent
