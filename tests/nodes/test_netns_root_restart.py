"""A node's whole root restarts (a field vehicle reboots) while the other node runs on
(docs/bus.md, "Several nodes"; mrss/bus/border.py), through real processes on two hosts:
network namespaces as in test_netns.py.

NEEDS ROOT (CI runs as root); skipped without it, unless MRSS_REQUIRE_NETNS=1.

Node base runs a pinger and a listener of field's talker; node field a talker and an
echo, the listener of base's pinger. Each talker restarts once, so each peer's bar for
it stands at its incarnation 2. Then every process of field dies at once (SIGKILL to
everything in its namespace: the power goes) and `mrss supervise --node field` starts
again with the same run directory: its talker runs as incarnation 1 of a new run, under
a new key. The listener on base keeps hearing it; the last run's genuine message, put
on field's bus again, is refused at base's border and counted; what base's border
minted for the last run, put on base's bus again, is refused by the listener as a dead
incarnation; a forgery is still refused. Then base's root dies the same way and starts
again while field runs on: the echo on field hears base's new run's pinger.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from mrss.cli import main
from mrss.messages import Envelope, Heartbeat, LogRecord, encode, within_run
from mrss.testing import wait_until
from tests.nodes.test_netns import Net, Procs, net  # noqa: F401 (the fixture)
from tests.nodes.test_netns_incarnations import (
    HUGE,
    STALE,
    UNPROVEN,
    Bus,
    _publisher,
    _through,
    _wait_bus,
)

HERE = Path(__file__).parent
ROOT = HERE.parents[1]
# What each node's test subscriber records: the listeners' reports, the refusals, and the
# talkers' own messages (as that node's bus carries them: a peer's, re-minted).
PREFIXES = ["log.listener", "log.echo", "log.talker", "log.pinger", "edge.rejections"]


@dataclass
class Nodes:
    """The two nodes of project noderestart, each `mrss supervise --node` in its
    namespace, and a recording subscriber on each node's bus."""

    net: Net
    root: Path
    procs: Procs = field(default_factory=Procs)
    buses: dict[str, Bus] = field(default_factory=dict)
    roots: dict[str, subprocess.Popen[bytes]] = field(default_factory=dict)

    def ns(self, node: str) -> str:
        return self.net.a if node == "base" else self.net.b

    def run_dir(self, node: str) -> Path:
        return self.root / f"run-{node}"

    def start(self, node: str) -> Bus:
        env = {**os.environ, "MRSS_PROJECTS": str(self.root), "PYTHONPATH": str(ROOT)}
        self.run_dir(node).mkdir(exist_ok=True)  # kept: each run's key after the last
        self.roots[node] = self.procs.start(
            self.ns(node), [sys.executable, "-m", "mrss", "supervise", "noderestart",
                            "--node", node, "--no-tui", "--run-dir", str(self.run_dir(node))],
            self.root / f"{node}.{len(self.procs.all)}.log", env)
        _wait_bus(self.run_dir(node))
        self.buses[node] = Bus(self.run_dir(node), PREFIXES)
        return self.buses[node]

    def power_off(self, node: str) -> None:
        """Every process of `node` killed at once, as when its host loses power."""
        self.buses.pop(node).sub.close()

        def all_dead() -> bool:
            listed = subprocess.run(["ip", "netns", "pids", self.ns(node)], check=True,
                                    capture_output=True, text=True, timeout=10).stdout
            alive = [int(p) for p in listed.split() if not _zombie(int(p))]
            for pid in alive:
                try:
                    os.kill(pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
            return not alive

        wait_until(all_dead, 30, message=f"every process of node {node} killed")
        self.roots[node].wait(timeout=30)

    def kill_component(self, node: str, component: str, inc: int) -> None:
        os.kill(int((self.run_dir(node) / f"{component}.{inc}.started").read_text()),
                signal.SIGKILL)

    def logs(self) -> str:
        return "".join(p.read_text(errors="replace") for p in self.root.glob("*.*.log"))


@pytest.fixture()
def nodes(net: Net, monkeypatch: pytest.MonkeyPatch) -> Iterator[Nodes]:  # noqa: F811
    root = Path(tempfile.mkdtemp(prefix="mrss-noderestart-"))
    both = Nodes(net, root)
    try:
        folder = root / "noderestart"
        folder.mkdir()
        text = (HERE / "nodes_project" / "restart.toml.in").read_text()
        (folder / "project.toml").write_text(text.replace("@BASE@", net.base)
                                             .replace("@FIELD@", net.field))
        monkeypatch.setenv("MRSS_PROJECTS", str(root))
        assert main(["keys", "noderestart"]) == 0
        yield both
        assert "Traceback" not in both.logs()
    finally:
        for bus in both.buses.values():
            bus.sub.close()
        both.procs.close()
        shutil.rmtree(root, ignore_errors=True)


def _zombie(pid: int) -> bool:
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return True  # gone
    return stat.rpartition(")")[2].split()[0] == "Z"


def _keeps_hearing(bus: Bus, src: str, by: str, number: int) -> None:
    def count() -> int:
        return sum(1 for n, _ in bus.taken(src, by) if n == number)
    before = count()
    wait_until(lambda: count() >= before + 5, 30,
               message=f"{by} still hears {src} numbered {number}")


def _heard_after(bus: Bus, src: str, by: str, above: int, at_least: int = 5) -> int:
    """Wait until `by` took `at_least` ticks of `src` numbered above `above`; the number."""
    def news() -> list[int]:
        return [n for n, _ in bus.taken(src, by) if n > above]
    wait_until(lambda: len(news()) >= at_least, 60,
               message=f"{by} hears {src} numbered above {above}")
    return news()[-1]


def _last(bus: Bus, src: str, by: str) -> int:
    return max(n for n, _ in bus.taken(src, by))


def _envelope(bus: Bus, src: str, number: int) -> Envelope:
    """A message of `src` numbered `number`, as `bus` carried it (with its credential)."""
    return wait_until(lambda: [e for e in bus.envelopes() if e.src == src and
                               e.inc == number and isinstance(e.body, LogRecord)], 30,
                      message=f"a message of {src} numbered {number}")[-1]


def _again(env: Envelope, message: str) -> tuple[bytes, bytes]:
    """A message of env's sender with env's incarnation and credential: sent again."""
    return encode(LogRecord(component=env.src, level="INFO", message=message),
                  src=env.src, inc=env.inc, cred=env.cred)


@pytest.mark.timeout(300)
def test_a_nodes_new_run_is_heard_and_its_last_run_refused(nodes: Nodes) -> None:
    base, fld = nodes.start("base"), nodes.start("field")
    wait_until(lambda: base.heard(inc=1) and fld.heard("pinger", inc=1, by="echo"), 60,
               message="each node hears the other's talker")
    # each talker restarts once: the peer's bar stands at incarnation 2 of the first run
    nodes.kill_component("field", "talker", 1)
    nodes.kill_component("base", "pinger", 1)
    wait_until(lambda: len(base.heard(inc=2)) >= 3 and
               len(fld.heard("pinger", inc=2, by="echo")) >= 3, 60,
               message="each node hears the other's restarted talker")
    first_run = _last(base, "talker", "listener")
    assert within_run(first_run) == 2
    old_on_field = _envelope(fld, "talker", 2)  # as field's bus carried it: field's key
    old_on_base = _envelope(base, "talker", first_run)  # as base's border minted it

    # field loses power and starts again: its talker is incarnation 1 of a new run
    nodes.power_off("field")
    fld = nodes.start("field")
    wait_until(lambda: (nodes.run_dir("field") / "talker.1.started").exists(), 60,
               message="field's talker started again")
    second_run = _heard_after(base, "talker", "listener", first_run)
    assert within_run(second_run) == 1  # numbered from 1 again, and believed on base

    # the last run's genuine message, sent again on field's bus: refused at base's border
    border_before = base.refused("bus", UNPROVEN)
    on_field = _publisher(nodes.run_dir("field"))
    try:
        _through(base, on_field, _again(old_on_field, "tick replayed-at-field"))
        forged = encode(Heartbeat(component="talker", pid=1), src="talker", inc=HUGE)
        _through(base, on_field, forged)  # and a forgery, as before
    finally:
        on_field.close()
    wait_until(lambda: base.refused("bus", UNPROVEN) >= border_before + 2, 30,
               message="base's border counted the last run's message and the forgery")
    # what base's border minted for the last run, sent again on base's bus: a dead one
    stale_before = base.refused("listener", STALE)
    on_base = _publisher(nodes.run_dir("base"))
    try:
        _through(base, on_base, _again(old_on_base, "tick replayed-at-base"))
    finally:
        on_base.close()
    wait_until(lambda: base.refused("listener", STALE) > stale_before, 30,
               message="the listener refused the last run's minted message as dead")
    assert not [t for t in base.heard() if t.startswith("replayed")]
    _keeps_hearing(base, "talker", "listener", second_run)

    # base loses power and starts again while field runs on: field hears its new run
    pinger_first = _last(fld, "pinger", "echo")
    assert within_run(pinger_first) == 2
    nodes.power_off("base")
    base = nodes.start("base")
    pinger_second = _heard_after(fld, "pinger", "echo", pinger_first)
    assert within_run(pinger_second) == 1
    _heard_after(base, "talker", "listener", 0)  # and base's new listener hears field
