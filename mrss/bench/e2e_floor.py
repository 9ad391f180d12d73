"""The physical floor of `mrss bench e2e`'s path: raw ZeroMQ one-way latency per hop.

An event of the e2e bench crosses processes: bench -> bus proxy -> reasoner -> bus proxy
-> RCL (4 hops; 2 with direct delivery, which has no proxy). No bus built on ZeroMQ can
cross a hop faster than plain pyzmq PUB/SUB between two processes over ipc, sending MRSS
envelopes (`mrss bench bus`'s raw reference, mrss/bench/bus_raw.py). Its one-way time is
half the round trip of `pings` sequential ping/pongs, measured in the same run as the
e2e rows; the floor of a path is that one-way time times its hops.
"""

from __future__ import annotations

import tempfile
from contextlib import ExitStack
from dataclasses import dataclass

from mrss.bench.bus import _peer
from mrss.bench.report import BenchReport, Relation
from mrss.bench.restart import percentile

PROXY_HOPS = ("bench -> proxy", "proxy -> reasoner", "reasoner -> proxy", "proxy -> RCL")
DIRECT_HOPS = ("bench -> reasoner", "reasoner -> RCL")


@dataclass(frozen=True)
class Floor:
    """Raw ZeroMQ ipc one-way latency between two processes (ms), from round trips."""

    one_way_ms: list[float]

    @property
    def p50(self) -> float:
        return percentile(self.one_way_ms, 50)

    @property
    def p99(self) -> float:
        return percentile(self.one_way_ms, 99)

    def of(self, hops: int) -> float:
        """The floor of a path of `hops` process hops: its p50 one-way times `hops`."""
        return hops * self.p50


def measure(pings: int) -> Floor:
    """`pings` round trips of raw pyzmq PUB/SUB between two processes, over ipc."""
    with ExitStack() as stack:
        tmp = stack.enter_context(tempfile.TemporaryDirectory(prefix="mrss-bench-floor-"))
        spec = {"kind": "raw", "driver": f"ipc://{tmp}/raw-driver.sock",
                "responder": f"ipc://{tmp}/raw-responder.sock"}
        driver, responder = _peer(stack, "driver", spec), _peer(stack, "responder", spec)
        responder.wait_ready()
        driver.wait_ready()
        rtts_us = driver.command(f"pings {pings}", timeout=120)["rtt_us"]
    return Floor([rtt / 2 / 1000 for rtt in rtts_us])


def report(report: BenchReport, floor: Floor, quiet_p50: float) -> None:
    """The floor's rows (with the proxy and direct), its target and its note."""
    for label, hops in ((f"{len(PROXY_HOPS)} hops", PROXY_HOPS),
                        (f"{len(DIRECT_HOPS)} hops, direct bus", DIRECT_HOPS)):
        report.add_row(f"physical floor: raw zmq ipc one-way x {label}", "-",
                       len(floor.one_way_ms), floor.of(len(hops)), len(hops) * floor.p99,
                       None, None)
    report.target(f"quiet p50 percept -> first skill start <= 2x the physical floor of its "
                  f"{len(PROXY_HOPS)} process hops", quiet_p50, Relation.AT_MOST,
                  2 * floor.of(len(PROXY_HOPS)),
                  f"2 x {len(PROXY_HOPS)} x raw zmq ipc one-way p50 "
                  f"({floor.p50 * 1000:.0f} us, half a round trip, this run)")
    report.notes.append(
        f"physical floor: the path's process hops ({', '.join(PROXY_HOPS)}; direct: "
        f"{', '.join(DIRECT_HOPS)}) times the one-way latency of plain pyzmq PUB/SUB "
        f"between two processes over ipc sending MRSS envelopes (half the round trip of "
        f"{len(floor.one_way_ms):,} ping/pongs, mrss/bench/bus_raw.py), measured in this run "
        f"before the system started: p50 {floor.p50 * 1000:.0f} us, p99 "
        f"{floor.p99 * 1000:.0f} us; its p99 column is hops x the one-way p99 (a bound, not "
        f"a measured path); the floor leaves out the agent's cycle, the journal commit and "
        f"the actor and skill hand-offs, which the path adds")
