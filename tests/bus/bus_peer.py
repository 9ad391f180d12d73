"""A bus client as its own OS process, for the multi-process bus tests.

    python -m tests.bus.bus_peer ENDPOINTS_JSON pub ROBOT [INTERVAL]
        publish RobotData(robot=ROBOT, data={"seq": n}) for n = 1, 2, ... until killed
    python -m tests.bus.bus_peer ENDPOINTS_JSON sub PREFIX...
        print "<topic> <src> <seq>" for every message received
    python -m tests.bus.bus_peer ENDPOINTS_JSON rsend COUNT RATE [GATE]
        send COUNT ActionRequests on the reliable channel at about RATE a second, wait
        until all are acknowledged, print "acked COUNT"; with GATE, send only the first
        GATE of them until a line "upto N" on stdin lets the first N go
    python -m tests.bus.bus_peer ENDPOINTS_JSON rrecv
        print "handled <uuid>" for every handler call of a reliable receiver

Each prints "ready" once its sockets exist, and stops on SIGTERM.
"""

from __future__ import annotations

import json
import signal
import sys
import threading
import time

from mrss.bus import BusEndpoints, Publisher, ReliableReceiver, ReliableSender, Subscriber
from mrss.messages import ActionRequest, Envelope, RobotData


def main(argv: list[str]) -> int:
    endpoints = BusEndpoints.from_dict(json.loads(argv[0]))
    mode, args = argv[1], argv[2:]
    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda signum, frame: stop.set())
    if mode == "pub":
        with Publisher(endpoints, src=f"pub-{args[0]}") as pub:
            interval = float(args[1]) if len(args) > 1 else 0.002
            print("ready", flush=True)
            seq = 0
            while not stop.is_set():
                seq += 1
                pub.publish(RobotData(robot=args[0], data={"seq": seq}))
                stop.wait(interval)  # pacing, not synchronisation
    elif mode == "sub":
        with Subscriber(endpoints, prefixes=args) as sub:
            print("ready", flush=True)
            while not stop.is_set():
                env = sub.recv(timeout=0.1)
                if env is not None and isinstance(env.body, RobotData):
                    print(env.topic, env.src, env.body.data["seq"], flush=True)
    elif mode == "rsend":
        count, rate = int(args[0]), float(args[1])
        gate = _Gate(int(args[2]) if len(args) > 2 else count, stop)
        with ReliableSender(endpoints, src="sender", channel="action") as tx:
            print("ready", flush=True)
            started = time.monotonic()
            for n in range(count):
                if not gate.wait_past(n):
                    return 0
                tx.send(ActionRequest(uuid=f"a{n}", name="go", args=[n]))
                ahead = started + (n + 1) / rate - time.monotonic()
                if ahead > 0:
                    stop.wait(ahead)  # pacing, not synchronisation
            ok = tx.flush(timeout=60)
            print(f"acked {count}" if ok else f"unacked {tx.pending()}", flush=True)
            print(f"resent {tx.resent}", flush=True)
    elif mode == "rrecv":
        lock = threading.Lock()

        def handle(env: Envelope) -> None:
            assert isinstance(env.body, ActionRequest)
            with lock:
                sys.stdout.write(f"handled {env.body.uuid}\n")
                sys.stdout.flush()

        with ReliableReceiver(endpoints, src="receiver", channel="action", handler=handle):
            print("ready", flush=True)
            stop.wait()
    else:
        print(f"unknown mode {mode}", file=sys.stderr)
        return 2
    return 0


class _Gate:
    """How many messages the test lets the sender send: "upto N" lines on stdin raise it,
    so a test decides when the stream may go on (never a race against a rate)."""

    def __init__(self, limit: int, stop: threading.Event) -> None:
        self._limit = limit
        self._stop = stop
        self._raised = threading.Condition()
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        for line in sys.stdin:
            words = line.split()
            if len(words) == 2 and words[0] == "upto":
                with self._raised:
                    self._limit = max(self._limit, int(words[1]))
                    self._raised.notify_all()

    def wait_past(self, n: int) -> bool:
        """Wait until message `n` (from 0) may go; False if the peer is stopped first."""
        with self._raised:
            while n >= self._limit:
                if self._stop.is_set():
                    return False
                self._raised.wait(0.1)
        return True


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
