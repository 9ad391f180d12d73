"""Two MRSS nodes on two hosts, for real: network namespaces joined by a veth pair.

NEEDS ROOT (CI runs as root): it creates network namespaces (`ip netns add`) and veth
pairs. Without root, or without `ip`, the test is skipped, unless MRSS_REQUIRE_NETNS=1,
where it fails saying why.

Namespace A runs node base (the bus proxy and the RCL, whose robot ugv1 is reached
through node field), namespace B node field (its bus proxy and a beacon component),
each `mrss supervise tests-project --node NAME` with CurveZMQ keys made by `mrss keys`.
The test talks to base's bus over its ipc sockets (unix sockets are not bound to a
network namespace). It checks: field's supervision events reach base carrying their
node; cutting the link (`ip link set ... down`) makes base see field down
(`sup.node_down` naming its components), ugv1 unavailable and its running action
failed with `node_down`, a new request refused with it; restoring the link brings
field back (`sup.node_up`), ugv1 available, and a new action succeeds. The dashboard's
supervision model, fed what base's bus carried, has a level per node and marks field's
components "node down" while it is lost. Namespace C
holds a peer with a key the project does not know, and sends garbage: base refuses
both and logs them, and nothing of C reaches base's bus.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import tempfile
import uuid
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

from mrss.bus import BusEndpoints, ReliableSender, Stale, Subscriber
from mrss.bus.curve import generate, load_public
from mrss.cli import main
from mrss.messages import ActionRequest, ActionStatus, Envelope, Percept, RobotState, SupEvent
from mrss.messages.credentials import KEY_FILE
from mrss.testing import wait_until
from mrss.tui.models.supervision import SupervisionModel

HERE = Path(__file__).parent
PROJECT = HERE / "nodes_project"
REQUIRE = os.environ.get("MRSS_REQUIRE_NETNS") == "1"


def _why_not() -> str:
    if os.geteuid() != 0:
        return "not root: network namespaces need root (CI runs as root)"
    if shutil.which("ip") is None:
        return "the `ip` command (iproute2) is not installed"
    return ""


WHY_NOT = _why_not()
if WHY_NOT and REQUIRE:
    pytest.fail(f"MRSS_REQUIRE_NETNS=1 but the netns test cannot run: {WHY_NOT}",
                pytrace=False)
pytestmark = pytest.mark.skipif(bool(WHY_NOT), reason=WHY_NOT)


def ip(*args: str, ns: str | None = None) -> None:
    cmd = ["ip", "netns", "exec", ns, "ip", *args] if ns else ["ip", *args]
    subprocess.run(cmd, check=True, capture_output=True, timeout=10)


@dataclass
class Net:
    a: str
    b: str
    c: str
    base: str  # base's address (namespace A)
    field: str  # field's address (namespace B)
    rogue: str  # C's address
    link: str  # A's end of the A-B veth pair


@pytest.fixture()
def net() -> Iterator[Net]:
    tag = uuid.uuid4().hex[:6]
    third = int(tag[:2], 16) % 200 + 20
    a, b, c = (f"mrss-{x}-{tag}" for x in "abc")
    net = Net(a, b, c, f"10.{third}.1.1", f"10.{third}.1.2", f"10.{third}.2.2", f"va{tag}")
    made: list[str] = []
    try:
        for ns in (a, b, c):
            ip("netns", "add", ns)
            made.append(ns)
            ip("link", "set", "lo", "up", ns=ns)
        ip("link", "add", f"va{tag}", "type", "veth", "peer", "name", f"vb{tag}")
        ip("link", "set", f"va{tag}", "netns", a)
        ip("link", "set", f"vb{tag}", "netns", b)
        ip("link", "add", f"vc{tag}", "type", "veth", "peer", "name", f"vd{tag}")
        ip("link", "set", f"vc{tag}", "netns", a)
        ip("link", "set", f"vd{tag}", "netns", c)
        for ns, dev, addr in ((a, f"va{tag}", f"{net.base}/24"),
                              (b, f"vb{tag}", f"{net.field}/24"),
                              (a, f"vc{tag}", f"10.{third}.2.1/24"),
                              (c, f"vd{tag}", f"{net.rogue}/24")):
            ip("addr", "add", addr, "dev", dev, ns=ns)
            ip("link", "set", dev, "up", ns=ns)
        ip("route", "add", f"10.{third}.1.0/24", "via", f"10.{third}.2.1", ns=c)
        yield net
    finally:
        for ns in made:  # deleting a namespace deletes its veth ends
            subprocess.run(["ip", "netns", "del", ns], capture_output=True, timeout=10)


class Procs:
    def __init__(self) -> None:
        self.all: list[subprocess.Popen[bytes]] = []

    def start(self, ns: str, argv: list[str], log: Path, env: dict[str, str]
              ) -> subprocess.Popen[bytes]:
        with log.open("wb") as out:
            proc = subprocess.Popen(["ip", "netns", "exec", ns, *argv], stdout=out,
                                    stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                    env=env)
        self.all.append(proc)
        return proc

    def close(self) -> None:
        for proc in self.all:
            if proc.poll() is None:
                proc.send_signal(signal.SIGTERM)
        for proc in self.all:
            try:
                proc.wait(timeout=15)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait(timeout=5)


def _project(root: Path, net: Net) -> Path:
    folder = root / "nodesdemo"
    folder.mkdir()
    for name in ("rcl.py", "beacon.py"):
        shutil.copy(PROJECT / name, folder / name)
    text = (PROJECT / "project.toml.in").read_text()
    for key, value in (("@BASE@", net.base), ("@FIELD@", net.field), ("@PORT@", "5710"),
                       ("@PORT2@", "5710")):
        text = text.replace(key, value)
    (folder / "project.toml").write_text(text)
    return folder


def _has(log: Path, text: str) -> bool:
    return text in log.read_text(errors="replace")


@pytest.mark.timeout(90)
def test_two_nodes_lose_and_regain_each_other_and_refuse_a_stranger(
        net: Net, monkeypatch: pytest.MonkeyPatch) -> None:
    root = Path(tempfile.mkdtemp(prefix="mrss-nodes-"))
    procs = Procs()
    seen: list[Envelope] = []
    sub: Subscriber | None = None
    tx: ReliableSender | None = None
    try:
        folder = _project(root, net)
        env = {**os.environ, "MRSS_PROJECTS": str(root)}
        mrss = [sys.executable, "-m", "mrss"]
        monkeypatch.setenv("MRSS_PROJECTS", str(root))
        assert main(["keys", "nodesdemo"]) == 0
        run_a, run_b = root / "run-a", root / "run-b"
        run_a.mkdir()
        run_b.mkdir()
        log_a, log_b = root / "base.log", root / "field.log"
        procs.start(net.a, [*mrss, "supervise", "nodesdemo", "--node", "base", "--no-tui",
                            "--run-dir", str(run_a)], log_a, env)
        ep = BusEndpoints.ipc(run_a)
        wait_until(lambda: all(p.exists() for p in ep.ipc_paths()), timeout=20,
                   message="base's bus proxy listening")
        sub = Subscriber(ep, prefixes=["sup.", "action.status", "robot.", "percept"],
                         stale=Stale.KEEP)
        sub.start(seen.append)
        assert sub.wait_connected(10)
        wait_until(lambda: _has(log_a, "rcl: ready"), timeout=20, message="base's RCL ready")
        procs.start(net.b, [*mrss, "supervise", "nodesdemo", "--node", "field", "--no-tui",
                            "--run-dir", str(run_b)], log_b, env)

        def sup(event: str, child: str, *, fresh: bool = True) -> list[SupEvent]:
            return [e.body for e in list(seen) if isinstance(e.body, SupEvent)
                    and e.body.event == event and e.body.child == child
                    and not (fresh and e.body.detail.get("repeat"))]

        def tree() -> SupervisionModel:
            model = SupervisionModel(root="nodesdemo")
            for e in list(seen):
                if isinstance(e.body, SupEvent):
                    model.apply_event(e.body, e.src, e.ts)
            return model

        # field's own root events reach base, carrying their node
        beacon = wait_until(lambda: sup("start", "beacon"), timeout=20,
                            message="field's sup.start of beacon seen on base's bus")[0]
        assert beacon.node == "field"
        wait_until(lambda: sup("node_up", "field"), timeout=10, message="field up at base")
        # the dashboard's tree, from what base's bus carried: one level per node
        wait_until(lambda: {"nodesdemo/base/rcl", "nodesdemo/field/beacon"}
                   <= set(tree().nodes), timeout=10, message="both nodes in the tree")
        assert tree().nodes["nodesdemo/field"].kind == "node"

        def robot(available: bool) -> list[RobotState]:
            return [e.body for e in list(seen) if isinstance(e.body, RobotState)
                    and e.body.robot == "ugv1" and e.body.available is available]

        def status(uuid_: str, state: str) -> list[ActionStatus]:
            return [e.body for e in list(seen) if isinstance(e.body, ActionStatus)
                    and e.body.uuid == uuid_ and e.body.state == state]

        # as a reasoner base's root started: its envelopes prove inc 1 with base's key
        tx = ReliableSender(ep.keyed(run_a / KEY_FILE), src="reasoner", inc=1,
                            channel="action")
        tx.send(ActionRequest(uuid="long", name="patrol",
                              args=["ugv1", "g", list(range(2000))]))
        wait_until(lambda: status("long", "running"), timeout=20, message="action running")

        # the link is cut: field is lost for base
        downs_before = len(sup("node_down", "field"))
        ip("link", "set", net.link, "down", ns=net.a)
        failed = wait_until(lambda: status("long", "failed"), timeout=20,
                            message="the running action failed")[0]
        assert failed.cause == "node_down", failed
        down = sup("node_down", "field")[downs_before:]
        assert down and "beacon" in down[0].detail["components"]  # type: ignore[operator]
        assert down[0].node == "base"
        lost = wait_until(lambda: robot(False), timeout=10, message="ugv1 unavailable")[-1]
        assert lost.reason.startswith("node down"), lost
        cut = tree()
        assert cut.nodes["nodesdemo/field"].state == "down"
        assert cut.nodes["nodesdemo/field/beacon"].state == "node down"
        assert cut.nodes["nodesdemo/base/rcl"].state == "running"
        tx.send(ActionRequest(uuid="refused", name="patrol", args=["ugv1", "g", [1]]))
        refused = wait_until(lambda: status("refused", "failed"), timeout=20,
                             message="a request while field is lost refused")[0]
        assert refused.cause == "node_down", refused

        # the link is back: so is field, ugv1, and actions
        ups_before = len(sup("node_up", "field"))
        available_before = len(robot(True))
        ip("link", "set", net.link, "up", ns=net.a)
        wait_until(lambda: len(sup("node_up", "field")) > ups_before, timeout=20,
                   message="field up again")
        wait_until(lambda: len(robot(True)) > available_before, timeout=10,
                   message="ugv1 available again")
        tx.send(ActionRequest(uuid="after", name="patrol", args=["ugv1", "g", [1, 2]]))
        wait_until(lambda: status("after", "succeeded"), timeout=20,
                   message="an action after the return succeeded")

        # a stranger with a key of its own, and garbage: refused, logged, nothing gets in
        strangers = root / "stranger-keys"
        generate(strangers, "field")  # claims to be field, with a key nobody knows
        base_public = load_public(folder / "keys", "base").decode()
        rogue = procs.start(net.c, [sys.executable, str(HERE / "rogue_peer.py"),
                                    f"tcp://{net.base}:5710", base_public, str(strangers),
                                    "field"], root / "rogue.log", env)
        wait_until(lambda: _has(log_a, f"refused a peer at {net.rogue}"), timeout=20,
                   message="base logged the stranger's refusal")
        wait_until(lambda: _has(log_a, "refused a connection on its inbox"), timeout=20,
                   message="base logged the garbage connection")
        assert rogue.poll() is None, "the stranger should still be trying"
        assert not [e for e in list(seen) if isinstance(e.body, Percept)]
        assert not [p for p in procs.all[:2] if p.poll() is not None], "a node died"
        assert "Traceback" not in log_a.read_text() + log_b.read_text()
    finally:
        if tx is not None:
            tx.close()
        if sub is not None:
            sub.close()
        procs.close()
        shutil.rmtree(root, ignore_errors=True)
