"""`mrss bench nodes`: what crossing to another node costs, and how fast a lost node is seen.

Two node proxies (`mrss.bench.node_peer`, each its own OS process with its own ipc bus)
linked over loopback tcp with CurveZMQ, as `mrss supervise --node` runs them. The
driver and responder of `mrss bench bus` (mrss.bench.bus_peers) measure round trips and
one-way streams: both on one node's bus (one host, the plain proxy) and across (driver
on node a, responder on node b: publisher -> proxy a -> CURVE tcp -> proxy b ->
subscriber and back). Then node b's proxy is SIGSTOPped (a host that stops answering,
its TCP connection left open) and SIGCONTed: the time until node a publishes
`sup.node_down` and `sup.node_up`, with the defaults (heartbeat 0.5 s, 4 misses).
"""

from __future__ import annotations

import json
import os
import signal
import statistics
import tempfile
import time
from contextlib import ExitStack
from pathlib import Path
from typing import Any

from mrss.bench.bus import _Child, _measure, _peer, _spawn
from mrss.bench.report import BenchReport
from mrss.bus import BusEndpoints, Stale, Subscriber
from mrss.bus.curve import generate
from mrss.messages import IncarnationKey, SupEvent
from mrss.testing import free_port, wait_until

INTERVAL, MISSES = 0.5, 4


def _node(stack: ExitStack, tmp: Path, me: str, ports: dict[str, int]) -> tuple[BusEndpoints,
                                                                                  _Child]:
    (tmp / me).mkdir(parents=True, exist_ok=True)
    # each node's own incarnation key, as its root writes one: the proxies' border
    ep = BusEndpoints.ipc(tmp / me).keyed(IncarnationKey.create(tmp / me).path)
    mesh = {"node": me, "inbox": f"tcp://127.0.0.1:{ports[me]}", "keys_dir": str(tmp / "keys"),
            "peers": {n: f"tcp://127.0.0.1:{p}" for n, p in ports.items() if n != me},
            "components": {n: [] for n in ports}, "interval": INTERVAL, "misses": MISSES,
            "max_skew": 5.0}
    child = _spawn(stack, "mrss.bench.node_peer", json.dumps(ep.to_dict()), json.dumps(mesh))
    return ep, child.wait_ready()


def _loss(node_b: _Child, watch: Subscriber, seen: list[SupEvent], times: int
          ) -> tuple[list[float], list[float]]:
    """Seconds from SIGSTOP of node b to node a's node_down, and SIGCONT to node_up."""
    down, up = [], []
    for _ in range(times):
        count = len(seen)
        stopped = time.monotonic()
        os.kill(node_b.proc.pid, signal.SIGSTOP)
        wait_until(lambda c=count: [e for e in seen[c:] if e.event == "node_down"],  # type: ignore[misc]
                   timeout=30, message="node_down", interval=0.001)
        down.append(time.monotonic() - stopped)
        count = len(seen)
        resumed = time.monotonic()
        os.kill(node_b.proc.pid, signal.SIGCONT)
        wait_until(lambda c=count: [e for e in seen[c:] if e.event == "node_up"],  # type: ignore[misc]
                   timeout=30, message="node_up", interval=0.001)
        up.append(time.monotonic() - resumed)
    return down, up


def run(quick: bool) -> BenchReport:
    rounds, pings, count, losses = (2, 100, 2_000, 1) if quick else (5, 1000, 20_000, 5)
    report = BenchReport("nodes", ["path", "messages", "delivered %", "msgs/s",
                                   "RTT p50 us", "RTT p99 us", "s median", "s max"],
                         quick=quick)
    load_before = os.getloadavg()[0]
    with ExitStack() as stack:
        tmp = Path(stack.enter_context(tempfile.TemporaryDirectory(prefix="mrss-bn-")))
        for name in ("a", "b"):
            generate(tmp / "keys", name)
        ports = {"a": free_port(), "b": free_port()}
        a, _ = _node(stack, tmp, "a", ports)
        b, node_b = _node(stack, tmp, "b", ports)
        seen: list[SupEvent] = []
        watch = Subscriber(a, prefixes=["sup.node_"], stale=Stale.KEEP)
        stack.callback(watch.close)
        watch.start(lambda env: seen.append(env.body) if isinstance(env.body, SupEvent)
                    else None)
        wait_until(lambda: [e for e in seen if e.event == "node_up"], timeout=20,
                   message="node b up at node a")
        plain = BusEndpoints.ipc(tmp / "plain")
        _spawn(stack, "mrss.bus.proxy", "--frontend", plain.frontend,
               "--backend", plain.backend).wait_ready()
        specs: dict[str, tuple[dict[str, Any], dict[str, Any]]] = {
            "one host (plain proxy, ipc)": ({"kind": "bus", "endpoints": plain.to_dict()},
                                            {"kind": "bus", "endpoints": plain.to_dict()}),
            "within node a (node proxy, ipc)": ({"kind": "bus", "endpoints": a.to_dict()},
                                                {"kind": "bus", "endpoints": a.to_dict()}),
            "node a -> node b (tcp, CURVE)": ({"kind": "bus", "endpoints": a.to_dict()},
                                              {"kind": "bus", "endpoints": b.to_dict()}),
            # supervised senders (inc 1): each message proven and re-minted at the border
            "node a -> node b, inc 1 (border)": (
                {"kind": "bus", "endpoints": a.to_dict(), "inc": 1},
                {"kind": "bus", "endpoints": b.to_dict(), "inc": 1}),
        }
        results = {}
        for name, (driver_spec, responder_spec) in specs.items():
            pair = {name: (_peer(stack, "driver", driver_spec),
                           _peer(stack, "responder", responder_spec))}
            for driver, responder in pair.values():
                responder.wait_ready()
                driver.wait_ready()
            results.update(_measure(pair, rounds, pings, {name: count}))
            for child in pair[name]:
                child.stop()
        down, up = _loss(node_b, watch, seen, losses)
    for name, r in results.items():
        report.add_row(name, r["messages"], round(100 * r["delivered"], 2), r["rate"],
                       r["p50"], r["p99"], None, None)
    window = INTERVAL * MISSES
    report.add_row("node b stopped -> sup.node_down at a", losses, None, None, None, None,
                   round(statistics.median(down), 3), round(max(down), 3))
    report.add_row("node b resumed -> sup.node_up at a", losses, None, None, None, None,
                   round(statistics.median(up), 3), round(max(up), 3))
    report.check(f"a lost node is seen within its silence window + one heartbeat "
                 f"({window + INTERVAL:g} s)", max(down) <= window + INTERVAL + 0.25)
    report.notes.append(
        "The time "
        f"to see a node lost is the silence window ({INTERVAL:g} s x {MISSES} misses) plus "
        "up to one heartbeat; its return, the next heartbeat (SIGSTOP/SIGCONT of node b's "
        "proxy process). Round trips and streams: "
        "bus_peers as in `mrss bench bus` (RobotData envelopes, ~160 bytes); crossing "
        "nodes, each message is also decoded and validated by the receiving proxy; "
        "with inc 1 (a supervised sender, as every component is) its credential is also "
        "checked with the sending node's incarnation key and re-minted with the "
        "receiving node's (mrss/bus/border.py); inc 0 claims nothing and passes as it is.")
    report.notes.append(f"Load average before/after: {load_before:.2f}/"
                        f"{os.getloadavg()[0]:.2f} on {os.cpu_count()} CPUs.")
    return report
