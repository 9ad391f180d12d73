"""The two OS processes of `mrss bench bus`: a driver and a responder, over our bus or MQTT.

    python -m mrss.bench.bus_peers driver|responder LINK_JSON
    python -m mrss.bench.bus_peers reliable-tx|reliable-rx LINK_JSON   (tx: stdin "send N")

LINK_JSON is {"kind": "bus", "endpoints": {...}[, "batching": false]} (or, with no proxy,
{"kind": "bus", "direct": {"driver": EP, "responder": EP}}: each side's Publisher binds
its EP, its Subscriber connects to the other's),
{"kind": "mqtt", "host", "port", "qos"}, {"kind": "raw", "driver": EP, "responder": EP
[, "batching": true]} (plain pyzmq PUB/SUB between the two processes, each binding its
own EP: the limit; batching as our publisher batches, received without a poll per
message) or
{"kind": "raw-proxy", "endpoints": {...}} (the same plain sockets through a bare
`zmq.proxy`, started by `python -m mrss.bench.bus_peers bare-proxy LINK_JSON`).
Both sides do the same application work on every transport: each message is a
RobotData encoded into an MRSS envelope by the sender and decoded and validated by the
receiver. Each process prints "ready", then one JSON result line.

The driver first says hello until the responder answers (both are then surely
subscribed), then runs commands from stdin: `pings N` measures N sequential round
trips, `stream N ID` sends N messages as fast as it can and repeats an end marker until
the responder confirms. The responder answers pings and hellos at once and, for each
stream, prints how many messages arrived and the time from the first to the last.
"""

from __future__ import annotations

import json
import signal
import socket
import sys
import threading
import time
from collections import deque
from typing import Any, Protocol

import paho.mqtt.client as mqtt
import zmq
from paho.mqtt.enums import CallbackAPIVersion

from mrss.bench.bus_raw import RawLink
from mrss.bus import BusEndpoints, Publisher, ReliableReceiver, ReliableSender, Subscriber
from mrss.errors import DecodeError
from mrss.messages import (
    Envelope,
    IdGenerator,
    Message,
    RobotData,
    decode,
    encode,
)

WARMUP_PINGS = 50
PAYLOAD = {"lat": 38.736946, "lon": -9.142685, "alt": 120.5, "battery": 0.87, "mode": "auto"}


class Link(Protocol):
    """Publish and receive MRSS messages over one transport."""

    def publish(self, msg: Message) -> None: ...
    def recv(self, timeout: float) -> Envelope | None: ...
    def close(self) -> None: ...


class BusLink:
    """Our bus: a Publisher and a Subscriber."""

    def __init__(self, endpoints: BusEndpoints, topics: list[str], src: str,
                 batching: bool = True, bind: bool = False, inc: int = 0) -> None:
        self.pub = Publisher(endpoints, src=src, inc=inc, batching=batching, bind=bind)
        self.sub = Subscriber(endpoints, prefixes=topics, name=src)

    def publish(self, msg: Message) -> None:
        self.pub.publish(msg)

    def recv(self, timeout: float) -> Envelope | None:
        return self.sub.recv(timeout)

    def close(self) -> None:
        self.sub.close()
        self.pub.close()


class MqttLink:
    """paho-mqtt on a broker, driven by its own network loop in this thread (no handoff)."""

    def __init__(self, host: str, port: int, qos: int, topics: list[str], src: str) -> None:
        self.qos = qos
        self.src = src
        self._ids = IdGenerator()
        self._inbox: deque[Envelope] = deque()
        self._subscribed = 0
        client = mqtt.Client(CallbackAPIVersion.VERSION2, client_id=f"{src}-{time.time()}")
        client.on_message = self._on_message
        client.on_subscribe = self._on_subscribe
        client.connect(host, port)
        # paho leaves Nagle on; with it, QoS 1 round trips wait on delayed ACKs (~40 ms).
        sock = client.socket()
        if isinstance(sock, socket.socket):
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        for topic in topics:
            client.subscribe(topic, qos=qos)
        self.client = client
        deadline = time.monotonic() + 10
        while self._subscribed < len(topics) and time.monotonic() < deadline:
            client.loop(timeout=0.05)

    def _on_subscribe(self, *args: Any) -> None:
        self._subscribed += 1

    def _on_message(self, client: mqtt.Client, userdata: Any, message: mqtt.MQTTMessage) -> None:
        try:
            self._inbox.append(decode(message.topic.encode(), message.payload))
        except DecodeError:
            pass

    def publish(self, msg: Message) -> None:
        topic, payload = encode(msg, src=self.src, msg_id=self._ids())
        self.client.publish(topic.decode(), payload, qos=self.qos)

    def recv(self, timeout: float) -> Envelope | None:
        deadline = time.monotonic() + timeout
        while not self._inbox:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                return None
            self.client.loop(timeout=min(remaining, 0.05))
        return self._inbox.popleft()

    def flush(self, timeout: float = 60.0) -> None:
        """Run the network loop until every queued publish has left (and, QoS 1, is acked)."""
        deadline = time.monotonic() + timeout
        while self.client.want_write() or self._unacked():
            if time.monotonic() > deadline:
                break
            self.client.loop(timeout=0.01)

    def _unacked(self) -> bool:
        return bool(self.qos and self.client._out_messages)  # paho keeps no public count

    def close(self) -> None:
        self.client.disconnect()


AnyLink = BusLink | MqttLink | RawLink


def make_link(spec: dict[str, Any], topics: list[str], src: str, role: str) -> AnyLink:
    if spec["kind"] == "raw":
        other = "responder" if role == "driver" else "driver"
        return RawLink(spec[role], spec[other], topics, src,
                       batching=spec.get("batching", False))
    if spec["kind"] == "raw-proxy":
        ends = spec["endpoints"]
        return RawLink(None, ends["backend"], topics, src, proxy_frontend=ends["frontend"])
    if spec["kind"] == "bus" and "direct" in spec:  # no proxy: each binds its publisher
        other = "responder" if role == "driver" else "driver"
        ends = BusEndpoints(spec["direct"][role], spec["direct"][other])
        return BusLink(ends, topics, src, bind=True)
    if spec["kind"] == "bus":
        return BusLink(BusEndpoints.from_dict(spec["endpoints"]), topics, src,
                       batching=spec.get("batching", True), inc=int(spec.get("inc", 0)))
    return MqttLink(spec["host"], int(spec["port"]), int(spec["qos"]), topics, src)


def _ctl(what: str, n: int = 0) -> RobotData:
    return RobotData(robot="ctl", data={"what": what, "n": n})


def _expect(link: Link, robot: str, key: str, value: object, timeout: float) -> bool:
    """Receive until a RobotData of `robot` with data[key] == value, or the timeout."""
    deadline = time.monotonic() + timeout
    while (remaining := deadline - time.monotonic()) > 0:
        env = link.recv(remaining)
        if (env is not None and isinstance(env.body, RobotData)
                and env.body.robot == robot and env.body.data.get(key) == value):
            return True
    return False


def join(link: AnyLink) -> None:
    """Say hello until the responder answers: both sides are then subscribed."""
    hello = 0
    while not _expect(link, "reply", "hello", hello, 0.05):
        hello += 1
        link.publish(_ctl("hello", hello))
        if hello > 400:
            raise SystemExit("responder never answered")


def round_trips(link: AnyLink, pings: int) -> dict[str, Any]:
    """`pings` sequential ping/pong round trips (after a few unmeasured ones), in us."""
    rtts = []
    for i in range(-WARMUP_PINGS, pings):
        started = time.perf_counter()
        link.publish(RobotData(robot="ping", data={"i": i}))
        if not _expect(link, "pong", "i", i, 5.0):
            raise SystemExit(f"ping {i} got no answer")
        if i >= 0:
            rtts.append((time.perf_counter() - started) * 1e6)
    return {"rtt_us": rtts}


def stream(link: AnyLink, count: int, stream_id: int) -> dict[str, Any]:
    """Send `count` messages as fast as possible, then an end marker until confirmed."""
    started = time.perf_counter()
    sends0 = _sends(link)
    for i in range(count):
        link.publish(RobotData(robot="bench", data={"s": stream_id, "i": i, **PAYLOAD}))
        if isinstance(link, MqttLink) and i % 64 == 0:
            link.client.loop(timeout=0)
    if isinstance(link, MqttLink | RawLink):
        link.flush()
    sent_s = time.perf_counter() - started
    sends = _sends(link) - sends0  # ZeroMQ messages the stream took (0: not ZeroMQ)
    for _ in range(300):
        link.publish(_ctl("end", stream_id))
        if _expect(link, "reply", "bye", stream_id, 0.1):
            break
    return {"sent": count, "send_s": sent_s, "zmq_messages": sends}


def _sends(link: AnyLink) -> int:
    """How many ZeroMQ messages `link` has sent (a batch counts once)."""
    if isinstance(link, BusLink):
        return link.pub.sends
    return link.sends if isinstance(link, RawLink) else 0


def drive(link: AnyLink) -> None:
    """Run the commands read from stdin: `pings N`, `stream N ID`; print each result."""
    for line in sys.stdin:
        command, *args = line.split()
        if command == "pings":
            result = round_trips(link, int(args[0]))
        elif command == "stream":
            result = stream(link, int(args[0]), int(args[1]))
        else:
            break
        print(json.dumps(result), flush=True)


def respond(link: AnyLink, stop: threading.Event) -> None:
    """Answer hellos and pings; count each stream and print its count when it ends."""
    streams: dict[int, list[float]] = {}  # id -> [received, first, last]
    reported: set[int] = set()
    while not stop.is_set():
        env = link.recv(0.1)
        if env is None or not isinstance(env.body, RobotData):
            continue
        robot, data = env.body.robot, env.body.data
        if robot == "bench":
            now = time.perf_counter()
            counts = streams.get(data["s"])
            if counts is None:
                counts = streams[data["s"]] = [0, now, now]
            counts[0] += 1
            counts[2] = now
        elif robot == "ping":
            link.publish(RobotData(robot="pong", data={"i": data["i"]}))
        elif data.get("what") == "hello":
            link.publish(RobotData(robot="reply", data={"hello": data["n"]}))
        elif data.get("what") == "end":
            if data["n"] not in reported:
                received, first, last = streams.get(data["n"], [0, 0.0, 0.0])
                print(json.dumps({"received": received, "elapsed_s": last - first}), flush=True)
                reported.add(data["n"])
            link.publish(RobotData(robot="reply", data={"bye": data["n"]}))


def reliable_send(endpoints: BusEndpoints, count: int) -> dict[str, Any]:
    """Send `count` messages on the reliable channel; time until all are acknowledged."""
    with ReliableSender(endpoints, src="bench-tx", channel="bench") as tx:
        tx.send(RobotData(robot="bench", data={"i": -1}))  # the receiver is then joined
        if not tx.flush(timeout=30):
            raise SystemExit("reliable receiver never answered")
        started = time.perf_counter()
        for i in range(count):
            tx.send(RobotData(robot="bench", data={"i": i, **PAYLOAD}))
        ok = tx.flush(timeout=120)
        elapsed = time.perf_counter() - started
        return {"sent": count, "acked": ok, "elapsed_s": elapsed, "resent": tx.resent}


def reliable_receive(endpoints: BusEndpoints, stop: threading.Event) -> None:
    ids: set[str] = set()
    calls = 0

    def handle(env: Envelope) -> None:
        nonlocal calls
        calls += 1
        ids.add(env.id)

    with ReliableReceiver(endpoints, src="bench-rx", channel="bench", handler=handle):
        print("ready", flush=True)
        stop.wait()
    print(json.dumps({"handled": calls, "unique": len(ids)}), flush=True)


def bare_proxy(endpoints: BusEndpoints) -> None:
    """libzmq's own proxy loop, nothing of ours: XSUB frontend, XPUB backend."""
    ctx: zmq.Context[zmq.Socket[bytes]] = zmq.Context.instance()
    frontend, backend = ctx.socket(zmq.XSUB), ctx.socket(zmq.XPUB)
    for sock, hwm in ((frontend, zmq.RCVHWM), (backend, zmq.SNDHWM)):
        sock.setsockopt(zmq.LINGER, 0)
        sock.setsockopt(hwm, 100_000)
    for path in endpoints.ipc_paths():
        path.parent.mkdir(parents=True, exist_ok=True)
    frontend.bind(endpoints.frontend)
    backend.bind(endpoints.backend)
    print("ready", flush=True)
    zmq.proxy(frontend, backend)


def main(argv: list[str]) -> int:
    role, spec = argv[0], json.loads(argv[1])
    if role == "bare-proxy":
        bare_proxy(BusEndpoints.from_dict(spec["endpoints"]))
        return 0
    stop = threading.Event()
    if role in ("responder", "reliable-rx"):  # these finish their loop and report
        signal.signal(signal.SIGTERM, lambda signum, frame: stop.set())
    if role == "reliable-tx":
        endpoints = BusEndpoints.from_dict(spec["endpoints"])
        print("ready", flush=True)
        command, count = sys.stdin.readline().split()  # "send COUNT"
        print(json.dumps(reliable_send(endpoints, int(count))), flush=True)
        return 0
    if role == "reliable-rx":
        reliable_receive(BusEndpoints.from_dict(spec["endpoints"]), stop)
        return 0
    if role == "driver":
        link = make_link(spec, ["robot.reply.data", "robot.pong.data"], "bench-driver",
                         role)
        join(link)
        print("ready", flush=True)
        drive(link)
    else:
        link = make_link(spec, ["robot.ctl.data", "robot.ping.data", "robot.bench.data"],
                         "bench-responder", role)
        print("ready", flush=True)
        respond(link, stop)
    link.close()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
