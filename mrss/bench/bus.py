"""`mrss bench bus`: our ZeroMQ bus against paho-mqtt + Mosquitto, between two OS processes.

For each transport a driver and a responder process (`mrss.bench.bus_peers`) measure
sequential round trips (p50, p99) and then a one-way stream (messages per second at the
receiver, first to last message). Every message is an MRSS envelope, encoded and
decoded/validated on both transports alike. Our bus runs through its proxy process over
ipc and tcp; MQTT through a private Mosquitto at QoS 0 and QoS 1. The reliable channel
is measured too: messages per second until every one is acknowledged.
"""

from __future__ import annotations

import json
import math
import os
import queue
import statistics
import subprocess
import tempfile
import threading
from contextlib import ExitStack
from typing import Any

from mrss.bench.report import BenchReport, Relation
from mrss.bus import BusEndpoints
from mrss.interpreter import python_module
from mrss.testing import find_mosquitto, mosquitto_broker

QOS0 = "MQTT QoS 0"
RAW = "raw zmq"  # + " ipc" / " tcp": pyzmq + msgpack between the two processes, no proxy
BATCHED = ", batched"  # + the raw row batched as our publisher batches, no poll per message
BARE = f"{RAW} ipc, bare proxy"  # the same through libzmq's zmq.proxy: the cost of a hop
DIRECT = "bus ipc, no proxy"
DIRECT_IPC = "bus ipc, direct"  # [bus] delivery = "direct": the proxy only introduces
DIRECT_TCP = "bus tcp, direct"  # our Publisher (bind=True) and Subscriber, connected directly


class _Child:
    """A child process whose stdout lines are read on a thread, with timeouts."""

    def __init__(self, argv: list[str]) -> None:
        self.argv = argv
        self.proc = subprocess.Popen(argv, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     stderr=subprocess.PIPE, text=True)
        self._lines: queue.Queue[str | None] = queue.Queue()
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self._lines.put(line.strip())
        self._lines.put(None)

    def line(self, timeout: float) -> str:
        try:
            line = self._lines.get(timeout=timeout)
        except queue.Empty:
            line = None
        if line is None:
            err = self.stop()
            raise RuntimeError(f"{' '.join(self.argv[2:4])}: no output within {timeout}s\n{err}")
        return line

    def result(self, timeout: float) -> dict[str, Any]:
        out: dict[str, Any] = json.loads(self.line(timeout))
        return out

    def command(self, line: str, timeout: float) -> dict[str, Any]:
        assert self.proc.stdin is not None
        self.proc.stdin.write(line + "\n")
        self.proc.stdin.flush()
        return self.result(timeout)

    def stop(self) -> str:
        """End the child; what it wrote on stderr (for a failure's message)."""
        if self.proc.stdin is not None and not self.proc.stdin.closed:
            self.proc.stdin.close()  # a driver waiting for commands ends on EOF
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        err = ""
        if self.proc.stderr is not None and not self.proc.stderr.closed:
            err = self.proc.stderr.read()
        for stream in (self.proc.stdout, self.proc.stderr):
            if stream is not None:
                stream.close()
        return err


    def wait_ready(self, timeout: float = 30) -> _Child:
        if not self.line(timeout).startswith("ready"):
            raise RuntimeError(f"{self.argv[2:4]}: did not start")
        return self


def _spawn(stack: ExitStack, *args: str) -> _Child:
    """Start `python -P -m ARGS`; it is stopped when `stack` closes. Not yet waited for."""
    child = _Child(python_module(*args))
    stack.callback(child.stop)
    return child


def _peer(stack: ExitStack, role: str, spec: dict[str, Any]) -> _Child:
    return _spawn(stack, "mrss.bench.bus_peers", role, json.dumps(spec))


def _measure(pairs: dict[str, tuple[_Child, _Child]], rounds: int, pings: int,
             streams: dict[str, int]) -> dict[str, dict[str, Any]]:
    """Round trips and streams for every transport, interleaved round by round.

    Interleaving spreads the machine's background noise over all transports alike.
    """
    rtts: dict[str, list[float]] = {name: [] for name in pairs}
    rates: dict[str, list[float]] = {name: [] for name in pairs}
    received = dict.fromkeys(pairs, 0)
    zmq_messages = dict.fromkeys(pairs, 0)
    for r in range(rounds):
        order = list(pairs)[r % len(pairs):] + list(pairs)[:r % len(pairs)]
        for name in order:
            rtts[name] += pairs[name][0].command(f"pings {pings}", timeout=120)["rtt_us"]
        for name in order:
            driver, responder = pairs[name]
            zmq_messages[name] += driver.command(f"stream {streams[name]} {r}",
                                                 timeout=180).get("zmq_messages", 0)
            got = responder.result(timeout=30)
            received[name] += got["received"]
            if got["elapsed_s"] > 0:
                rates[name].append(got["received"] / got["elapsed_s"])
    results = {}
    for name in pairs:
        ordered = sorted(rtts[name])
        results[name] = {
            "messages": streams[name] * rounds,
            "delivered": received[name] / (streams[name] * rounds),
            "rate": statistics.median(rates[name]) if rates[name] else None,
            "p50": _percentile(ordered, 0.50),
            "p99": _percentile(ordered, 0.99),
            # envelopes per ZeroMQ message in the streams: how much batching happened
            "per_message": (streams[name] * rounds / zmq_messages[name]
                            if zmq_messages[name] else None),
        }
    return results


def _reliable(sender: _Child, receiver: _Child, count: int) -> dict[str, Any]:
    sent = sender.command(f"send {count}", timeout=180)
    receiver.proc.terminate()
    handled = receiver.result(timeout=30)
    # One warm-up message precedes the timed ones; each must be handled exactly once.
    exactly_once = handled["handled"] == handled["unique"] == count + 1 and sent["acked"]
    return {
        "messages": count,
        "delivered": (handled["unique"] - 1) / count if exactly_once else 0.0,
        "rate": count / sent["elapsed_s"],
        "resent": sent["resent"],
    }


def _percentile(sorted_values: list[float], p: float) -> float:
    return sorted_values[max(0, math.ceil(p * len(sorted_values)) - 1)]


def run(quick: bool) -> BenchReport:
    """Measure every transport in this run and compare against MQTT QoS 0."""
    rounds = 2 if quick else 7
    pings = 100 if quick else 1000
    # Per round. With batching, 50,000 stays within our queue limits (DEFAULT_HWM ZeroMQ
    # messages per hop) even when the receiver falls behind; unbatched plain pub/sub and
    # Mosquitto's default queues may drop some, which 'delivered %' shows.
    count = 5_000 if quick else 50_000
    reliable = 2_000 if quick else 100_000
    report = BenchReport(
        name="bus", quick=quick,
        columns=["transport", "messages", "delivered %", "msgs/s", "/ best raw", "/ QoS 0",
                 "RTT p50 us", "RTT p99 us", "p50, p99 / best raw", "p50, p99 / QoS 0",
                 "envelopes / zmq msg"])
    load_before = os.getloadavg()[0]
    with ExitStack() as stack:
        tmp = stack.enter_context(tempfile.TemporaryDirectory(prefix="mrss-bench-"))
        # One proxy per transport, as each MQTT variant gets its own broker: the peers of
        # different transports use the same topics.
        ipc, tcp = BusEndpoints.ipc(tmp), BusEndpoints.tcp_loopback()
        ipc_plain = BusEndpoints.ipc(os.path.join(tmp, "plain"))
        ipc_direct = BusEndpoints.ipc(os.path.join(tmp, "direct"), direct=True)
        tcp_direct = BusEndpoints.tcp_loopback(direct=True)
        for ep in (ipc, tcp, ipc_plain, ipc_direct, tcp_direct):
            _spawn(stack, "mrss.bus.proxy", "--frontend", ep.frontend,
                   "--backend", ep.backend, *(["--direct"] if ep.direct else [])).wait_ready()
        specs: dict[str, dict[str, Any]] = {
            "bus ipc": {"kind": "bus", "endpoints": ipc.to_dict()},
            "bus tcp": {"kind": "bus", "endpoints": tcp.to_dict()},
            "bus ipc, no batching": {"kind": "bus", "endpoints": ipc_plain.to_dict(),
                                     "batching": False},
            DIRECT_IPC: {"kind": "bus", "endpoints": ipc_direct.to_dict()},
            DIRECT_TCP: {"kind": "bus", "endpoints": tcp_direct.to_dict()},
        }
        raw_tcp = BusEndpoints.tcp_loopback()
        specs[f"{RAW} ipc"] = {"kind": "raw", "driver": f"ipc://{tmp}/raw-driver.sock",
                               "responder": f"ipc://{tmp}/raw-responder.sock"}
        specs[f"{RAW} tcp"] = {"kind": "raw", "driver": raw_tcp.frontend,
                               "responder": raw_tcp.backend}
        batched_tcp = BusEndpoints.tcp_loopback()
        specs[f"{RAW} ipc{BATCHED}"] = {
            "kind": "raw", "batching": True, "driver": f"ipc://{tmp}/rawb-driver.sock",
            "responder": f"ipc://{tmp}/rawb-responder.sock"}
        specs[f"{RAW} tcp{BATCHED}"] = {"kind": "raw", "batching": True,
                                        "driver": batched_tcp.frontend,
                                        "responder": batched_tcp.backend}
        specs[DIRECT] = {"kind": "bus", "direct": {
            "driver": f"ipc://{tmp}/direct-driver.sock",
            "responder": f"ipc://{tmp}/direct-responder.sock"}}
        bare = BusEndpoints.ipc(os.path.join(tmp, "bare"))
        _peer(stack, "bare-proxy", {"endpoints": bare.to_dict()}).wait_ready()
        specs[BARE] = {"kind": "raw-proxy", "endpoints": bare.to_dict()}
        streams = dict.fromkeys(specs, count)
        binary = find_mosquitto()
        if binary is None:
            report.notes.append("mosquitto not found: MQTT rows are missing")
        else:
            for qos in (0, 1):
                # One broker each, as each bus transport has its own proxy. Nagle off on
                # both ends, as on our side: else QoS 1 waits on delayed ACKs.
                broker = stack.enter_context(
                    mosquitto_broker(binary))
                name = f"MQTT QoS {qos}"
                specs[name] = {"kind": "mqtt", "host": broker.host, "port": broker.port,
                               "qos": qos}
                streams[name] = count if qos == 0 else count // 5
        # Start every process at once (interpreter start-up dominates a quick run).
        pairs = {name: (_peer(stack, "driver", spec), _peer(stack, "responder", spec))
                 for name, spec in specs.items()}
        reliable_pairs = {
            f"bus reliable {name[4:]}": (_peer(stack, "reliable-tx", specs[name]),
                                         _peer(stack, "reliable-rx", specs[name]))
            for name in ("bus ipc", "bus tcp", DIRECT_IPC)}
        for driver, responder in [*pairs.values(), *reliable_pairs.values()]:
            responder.wait_ready()
            driver.wait_ready()
        results = _measure(pairs, rounds, pings, streams)
        for name, (sender, receiver) in reliable_pairs.items():
            results[name] = _reliable(sender, receiver, reliable)
    _fill(report, results, rounds * pings)
    report.notes.append(f"Load average before/after: {load_before:.2f}/{os.getloadavg()[0]:.2f} "
                        f"on {os.cpu_count()} CPUs (other work on the machine adds noise, "
                        "mostly to p99).")
    return report


def _ratio(a: float | None, b: float | None) -> float | None:
    return a / b if a is not None and b else None


def transport(name: str) -> str:
    """The transport a row runs on, for its raw reference: MQTT is TCP."""
    return "tcp" if " tcp" in name or name.startswith("MQTT") else "ipc"


def best_raw(results: dict[str, dict[str, Any]], on: str) -> dict[str, Any]:
    """The best raw figures on transport `on` over its raw rows (plain and batched, not
    through a proxy): the highest msgs/s, the lowest p50 and p99, each with its row."""
    rows = {name: r for name, r in results.items()
            if name in (f"{RAW} {on}", f"{RAW} {on}{BATCHED}")}
    rated = [(r["rate"], name) for name, r in rows.items() if r.get("rate")]
    timed = [name for name, r in rows.items() if r.get("p50") is not None]
    rate, rate_row = max(rated) if rated else (None, "")
    p50_row = min(timed, key=lambda n: rows[n]["p50"]) if timed else ""
    p99_row = min(timed, key=lambda n: rows[n]["p99"]) if timed else ""
    return {"rate": rate, "rate_row": rate_row,
            "p50": rows[p50_row]["p50"] if p50_row else None, "p50_row": p50_row,
            "p99": rows[p99_row]["p99"] if p99_row else None, "p99_row": p99_row}


def _pair(r: dict[str, Any], base: dict[str, Any] | None) -> str | None:
    """'p50 ratio, p99 ratio' of a row's round trips against `base`'s."""
    if base is None or r.get("p50") is None or not base.get("p50"):
        return None
    return f"{r['p50'] / base['p50']:.2f}, {r['p99'] / base['p99']:.2f}"


BUS_ROWS = ("bus ipc", "bus tcp", DIRECT_IPC, DIRECT_TCP)  # the rows with targets
RELIABLE_ROWS = ("bus reliable ipc", "bus reliable tcp", "bus reliable ipc, direct")
# The performance issue's targets against the best raw row of the transport.
RTT_WITHIN = 1.2
RATE_AT_LEAST = 0.9
RELIABLE_RATE_AT_LEAST = 0.75


def _fill(report: BenchReport, results: dict[str, dict[str, Any]], pings: int) -> None:
    base = results.get(QOS0)
    limits = {on: best_raw(results, on) for on in ("ipc", "tcp")}
    for name, r in results.items():
        raw = limits[transport(name)]
        report.add_row(name, r["messages"], round(100 * r["delivered"], 2), r["rate"],
                       _ratio(r["rate"], raw["rate"]),
                       _ratio(r["rate"], base["rate"] if base else None),
                       r.get("p50"), r.get("p99"), _pair(r, raw), _pair(r, base),
                       r.get("per_message"))
    for name in BUS_ROWS:
        _targets(report, name, results[name], limits[transport(name)], base)
    for name in RELIABLE_ROWS:
        if name in results:
            raw = limits[transport(name)]
            report.target(f"{name}: throughput >= {RELIABLE_RATE_AT_LEAST:.0%} of the best "
                          "raw's", results[name].get("rate"), Relation.AT_LEAST,
                          RELIABLE_RATE_AT_LEAST * raw["rate"] if raw["rate"] else math.nan,
                          f"{RELIABLE_RATE_AT_LEAST} x {raw['rate_row']} "
                          f"({_us(raw['rate'])} msgs/s)")
    for on, raw in limits.items():
        report.notes.append(
            f"best raw {on}: msgs/s from '{raw['rate_row']}', RTT p50 from "
            f"'{raw['p50_row']}', p99 from '{raw['p99_row']}'")

    report.notes.append(
        f"RTT: {pings} sequential ping/pong round trips (in rounds, interleaved across "
        "transports, each after 50 unmeasured ones). msgs/s: median over the rounds of one "
        "sender streaming as fast as it can, counted at the receiver from first to last "
        "message; 'delivered' is the share that arrived (plain pub/sub and QoS 0 may drop "
        "under overload). Reliable rows: time until every message is acknowledged, each "
        "handled exactly once. MQTT QoS 1 streams a fifth as many messages (paho and "
        "Mosquitto defaults, 20 in flight). Raw zmq rows: plain pyzmq PUB/SUB sockets between "
        "the two processes (each binds its own, no proxy), the same envelope bytes, msgpack "
        "unpacked without the bus's validation, one ZeroMQ message per envelope and a poll "
        "per receive; ', batched' rows batch as our publisher does (up to 64 envelopes per "
        "ZeroMQ message) and receive without a poll per message: the fair limit for a bus "
        "that batches ('envelopes / zmq msg': how many envelopes a ZeroMQ message of the "
        "streams carried on average; the batching rule is a burst's, messages < 20 us "
        "apart, so a loaded machine batches less, bus and raw alike). Every '/ best raw' "
        "divides by the best raw figure on the row's "
        "transport (MQTT is TCP: raw tcp); 'bare proxy' is the same "
        "through a bare zmq.proxy (XSUB/XPUB, nothing of ours): the cost of a proxy hop. "
        "MQTT runs with TCP_NODELAY on paho's socket and set_tcp_nodelay in Mosquitto "
        "(without, QoS 1 round trips take ~45-90 ms).")
    report.notes.append("Every message is a RobotData MRSS envelope of ~160 bytes (encode, "
                        "decode and validate on both sides). Our publisher batches bursts "
                        "(messages < 20 us apart; docs/bus.md), so streams travel in batches "
                        "and round trips never do; 'no batching' shows the bus without it.")


def _targets(report: BenchReport, name: str, r: dict[str, Any], raw: dict[str, Any],
             base: dict[str, Any] | None) -> None:
    """The performance issue's bus targets for row `name`, against the best raw row of
    its transport and against MQTT QoS 0."""
    for q in ("p50", "p99"):
        report.target(f"{name}: RTT {q} within {RTT_WITHIN}x the best raw's", r.get(q),
                      Relation.AT_MOST, RTT_WITHIN * raw[q] if raw[q] else math.nan,
                      f"{RTT_WITHIN} x {raw[q + '_row']} {q} ({_us(raw[q])} us)")
    report.target(f"{name}: throughput >= {RATE_AT_LEAST:.0%} of the best raw's",
                  r.get("rate"), Relation.AT_LEAST,
                  RATE_AT_LEAST * raw["rate"] if raw["rate"] else math.nan,
                  f"{RATE_AT_LEAST} x {raw['rate_row']} ({_us(raw['rate'])} msgs/s)")
    qos0 = base or {}
    report.target(f"{name}: throughput >= 3x {QOS0}", r.get("rate"), Relation.AT_LEAST,
                  3 * qos0["rate"] if qos0.get("rate") else math.nan,
                  f"3 x {QOS0} ({_us(qos0.get('rate'))} msgs/s)")
    for q in ("p50", "p99"):
        report.target(f"{name}: RTT {q} below half of {QOS0}'s", r.get(q), Relation.BELOW,
                      qos0[q] / 2 if qos0.get(q) else math.nan,
                      f"0.5 x {QOS0} {q} ({_us(qos0.get(q))} us)")


def _us(value: float | None) -> str:
    return "-" if value is None else f"{value:,.0f}"
