"""Incarnations across nodes (docs/bus.md, "Who may claim an incarnation"; mrss/bus/
border.py), through real processes on two hosts: network namespaces as in test_netns.py.

NEEDS ROOT (CI runs as root); skipped without it, unless MRSS_REQUIRE_NETNS=1.

Node field (namespace B) runs a talker, node base (namespace A) a listener that repeats
on its bus what it takes from the talker; each node's root has a key of its own. The
test checks: the listener on base believes the talker's incarnation, proven by field's
key (base's border re-mints it); a forged heartbeat with a huge incarnation, sent by a
third process to field's bus, silences nobody: base's border refuses it and counts it
in the bus proxy's report, and the same forgery on base's own bus is refused and counted
by the listener; a real restart of the talker on field raises the bar on base: the
listener hears the new incarnation, and a genuine message of the dead one (its proof
valid, sent again) is refused there as a dead incarnation.
"""

from __future__ import annotations

import os
import re
import shutil
import signal
import sys
import tempfile
import threading
import uuid
from collections.abc import Iterator
from pathlib import Path

import pytest
import zmq

from mrss.bus import BusEndpoints, Stale, Subscriber
from mrss.cli import main
from mrss.messages import Envelope, Heartbeat, LogRecord, Rejections, encode, within_run
from mrss.testing import wait_until
from tests.nodes.test_netns import Net, Procs, net  # noqa: F401 (the fixture)

HERE = Path(__file__).parent
ROOT = HERE.parents[1]
HUGE = 10**9
HEARD = re.compile(r"heard (\S+) (-?\d+) tick (\S+)")
UNPROVEN = "bus message from talker: an incarnation its supervisor did not start"
STALE = "bus message from talker: a dead incarnation"


class Bus:
    """What a node's bus carries, heard from its ipc sockets (not bound to a namespace)."""

    def __init__(self, run_dir: Path, prefixes: list[str]) -> None:
        self.endpoints = BusEndpoints.ipc(run_dir)
        self.seen: list[Envelope] = []
        self._lock = threading.Lock()
        self.sub = Subscriber(self.endpoints, prefixes=prefixes, stale=Stale.KEEP)
        self.sub.start(self._add)
        # a node started again finds its last run's socket files in place: the wait for
        # its new proxy is here, as long as a root's start may take on a loaded machine
        assert self.sub.wait_connected(60), f"no bus proxy greeted in {run_dir}"

    def _add(self, env: Envelope) -> None:
        with self._lock:
            self.seen.append(env)

    def envelopes(self) -> list[Envelope]:
        with self._lock:
            return list(self.seen)

    def heard(self, src: str = "talker", inc: int | None = None, by: str = "listener"
              ) -> list[str]:
        """What `by` took from `src` (of incarnation `inc`, as `src`'s own root counts)."""
        return [tick for number, tick in self.taken(src, by)
                if inc is None or within_run(number) == inc]

    def taken(self, src: str, by: str) -> list[tuple[int, str]]:
        """(incarnation as `by` knew it, tick) of what `by` took from `src`, in order: a
        peer node's incarnations as its border numbers them (docs/bus.md)."""
        records = [e.body.message for e in self.envelopes() if isinstance(e.body, LogRecord)
                   and e.body.component == by]
        found = [m for m in map(HEARD.fullmatch, records) if m and m[1] == src]
        return [(int(m[2]), m[3]) for m in found]

    def refused(self, component: str, kind: str) -> int:
        reports = [e.body for e in self.envelopes() if isinstance(e.body, Rejections)
                   and e.body.component == component]
        return reports[-1].counts.get(kind, 0) if reports else 0


def _wait_bus(run_dir: Path) -> None:
    wait_until(lambda: all(p.exists() for p in BusEndpoints.ipc(run_dir).ipc_paths()),
               timeout=30, message=f"the bus proxy of {run_dir.name} listening")


@pytest.fixture()
def door(net: Net, monkeypatch: pytest.MonkeyPatch) -> Iterator[tuple[Path, Path, Bus]]:  # noqa: F811
    root = Path(tempfile.mkdtemp(prefix="mrss-door-"))
    procs = Procs()
    base_bus: Bus | None = None
    try:
        folder = root / "nodedoor"
        folder.mkdir()
        text = (HERE / "nodes_project" / "door.toml.in").read_text()
        (folder / "project.toml").write_text(text.replace("@BASE@", net.base)
                                             .replace("@FIELD@", net.field))
        monkeypatch.setenv("MRSS_PROJECTS", str(root))
        assert main(["keys", "nodedoor"]) == 0
        env = {**os.environ, "MRSS_PROJECTS": str(root), "PYTHONPATH": str(ROOT)}
        runs = root / "run-a", root / "run-b"
        for (ns, node), run_dir in zip(((net.a, "base"), (net.b, "field")), runs,
                                       strict=True):
            run_dir.mkdir()
            procs.start(ns, [sys.executable, "-m", "mrss", "supervise", "nodedoor",
                             "--node", node, "--no-tui", "--run-dir", str(run_dir)],
                        root / f"{node}.log", env)
            _wait_bus(run_dir)
        base_bus = Bus(runs[0], ["log.listener", "edge.rejections"])
        wait_until(lambda: base_bus.heard(inc=1), 60,  # type: ignore[union-attr]
                   message="the listener on base hears the talker on field")
        yield runs[0], runs[1], base_bus
        logs = "".join((root / f"{n}.log").read_text(errors="replace")
                       for n in ("base", "field"))
        assert "Traceback" not in logs
    finally:
        if base_bus is not None:
            base_bus.sub.close()
        procs.close()
        shutil.rmtree(root, ignore_errors=True)


def _publisher(run_dir: Path) -> zmq.Socket[bytes]:
    sock: zmq.Socket[bytes] = zmq.Context.instance().socket(zmq.PUB)
    sock.setsockopt(zmq.LINGER, 0)
    sock.connect(BusEndpoints.ipc(run_dir).frontend)
    return sock


def _through(bus: Bus, sock: zmq.Socket[bytes], frames: tuple[bytes, bytes]) -> None:
    """Send `frames`, then a marker tick of an unsupervised sender from the same socket
    (so after it, in order, also across the nodes' link), until the listener has taken a
    marker: the frames have been through every door on their way by then."""
    sent = iter(range(1, 1_000_000))
    tag = uuid.uuid4().hex[:8]

    def marker_taken() -> bool:
        sock.send_multipart(frames)
        sock.send_multipart(encode(LogRecord(component="talker", level="INFO",
                                             message=f"tick {tag}-{next(sent)}"),
                                   src="marker", inc=0))
        return any(m.startswith(tag) for m in bus.heard("marker"))

    wait_until(marker_taken, 30, interval=0.2, message="the listener takes the marker")


def _keeps_hearing_the_talker(bus: Bus, inc: int) -> None:
    before = len(bus.heard(inc=inc))
    wait_until(lambda: len(bus.heard(inc=inc)) >= before + 5, 30,
               message=f"the listener still hears the talker's incarnation {inc}")


@pytest.mark.timeout(180)
def test_incarnations_are_proven_across_nodes_and_forgeries_refused(
        door: tuple[Path, Path, Bus]) -> None:
    run_a, run_b, base = door
    forged = encode(Heartbeat(component="talker", pid=1), src="talker", inc=HUGE)
    forged_tick = encode(LogRecord(component="talker", level="INFO", message="tick forged"),
                         src="talker", inc=HUGE)

    # on field's bus: base's border refuses them, counted in base's proxy report
    on_field = _publisher(run_b)
    try:
        _through(base, on_field, forged)
        _through(base, on_field, forged_tick)
    finally:
        on_field.close()
    _keeps_hearing_the_talker(base, 1)
    wait_until(lambda: base.refused("bus", UNPROVEN) >= 2, 30,
               message="base's border counted the forgeries")

    # on base's own bus: the listener's door refuses them with base's key
    on_base = _publisher(run_a)
    try:
        _through(base, on_base, forged)
        _through(base, on_base, forged_tick)
    finally:
        on_base.close()
    _keeps_hearing_the_talker(base, 1)
    assert "forged" not in base.heard()
    wait_until(lambda: base.refused("listener", UNPROVEN) >= 2, 30,
               message="the listener counted the forgeries")

    # a genuine message of the talker's first incarnation, as field's bus carries it
    field = Bus(run_b, ["log.talker"])
    try:
        genuine = wait_until(lambda: [e for e in field.envelopes() if e.inc == 1], 30,
                             message="a tick of the talker's incarnation 1 on field")[0]
    finally:
        field.sub.close()
    assert genuine.cred
    old = encode(LogRecord(component="talker", level="INFO", message="tick late"),
                 src="talker", inc=1, cred=genuine.cred)

    # a real restart on field raises the bar on base
    pid = int((run_b / "talker.1.started").read_text())
    os.kill(pid, signal.SIGKILL)
    wait_until(lambda: len(base.heard(inc=2)) >= 3, 60,
               message="the listener hears the restarted talker")
    stale_before = base.refused("listener", STALE)
    on_field = _publisher(run_b)
    try:
        _through(base, on_field, old)
    finally:
        on_field.close()
    assert "late" not in base.heard()
    wait_until(lambda: base.refused("listener", STALE) > stale_before, 30,
               message="the dead incarnation's message refused on base")
    _keeps_hearing_the_talker(base, 2)
