"""A short seeded campaign of node faults on the nodes project (the CI form).

NEEDS ROOT, `ip` and `nft` (CI runs as root): `python -m mrss chaos` runs each node of
tests/nodes/nodes_project (chaos.toml.in: base with the broker, events, reasoner and
RCL; field with the beacon and robot ugv1 behind it) in a network namespace of its own,
joined by a bridge, with CurveZMQ keys made by `mrss keys`, and cuts field off from base
twice (`node_partition`: nftables drops every packet) with 30 % loss in between
(`node_loss`). Without root, `ip` or `nft` the test is skipped, unless
MRSS_REQUIRE_NETNS=1, where it fails saying why.

It checks what the partition does and that the system heals from it: base sees field
down, ugv1 unavailable and the action running on it (or asked for meanwhile) failed
with `node_down`, never left running; when the partition heals ugv1 is available again,
the agent's retry runs the patrol again and it succeeds; the verdict holds, with
heals-to-same-state and no-robot-stuck judged and holding.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import uuid
from collections.abc import Iterator
from pathlib import Path

import pytest

from mrss.chaos.checker import Bounds, Invariant, Judgement, Outcome, check
from mrss.chaos.faults import why_no_nodes
from mrss.chaos.history import FILE_NAME, History, load
from mrss.chaos.report import summary, text
from mrss.config.loader import load_file

PROJECT = Path(__file__).resolve().parents[1] / "nodes" / "nodes_project"
REQUIRE = os.environ.get("MRSS_REQUIRE_NETNS") == "1"
CAMPAIGN = ["--faults", "4", "--seed", "6", "--kinds", "node_partition,node_loss,node_delay",
            "--interval", "3..4", "--duration", "2..4", "--operator-every", "2",
            "--warmup", "3", "--latch-bound", "10", "--cancel-bound", "10",
            "--converge-bound", "30"]


def _project(root: Path) -> Path:
    folder = root / "nodeschaos"
    folder.mkdir()
    for name in ("rcl.py", "beacon.py", "agent.asl", "events.py", "chaos.py"):
        shutil.copy(PROJECT / name, folder / name)
    third = int(uuid.uuid4().hex[:2], 16) % 200 + 20  # any: the namespaces are private
    text_ = (PROJECT / "chaos.toml.in").read_text()
    for key, value in (("@BASE@", f"10.{third}.1.1"), ("@FIELD@", f"10.{third}.1.2"),
                       ("@PORT@", "5710"), ("@PORT2@", "5710")):
        text_ = text_.replace(key, value)
    (folder / "project.toml").write_text(text_)
    return folder


def test_the_documented_node_campaign_is_this_one() -> None:
    doc = (Path(__file__).resolve().parents[2] / "docs" / "chaos.md").read_text()
    assert f"mrss chaos nodeschaos {' '.join(CAMPAIGN)}\n" in doc


@pytest.fixture(scope="module")
def campaign(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[int, History, dict]]:  # type: ignore[type-arg]
    root = tmp_path_factory.mktemp("nodechaos")
    folder = _project(root)
    why = why_no_nodes(load_file(folder / "project.toml"))
    if why:
        if REQUIRE:
            pytest.fail(f"MRSS_REQUIRE_NETNS=1 but the node campaign cannot run: {why}",
                        pytrace=False)
        pytest.skip(why)
    env = dict(os.environ, MRSS_PROJECTS=str(root))
    keys = subprocess.run([sys.executable, "-m", "mrss", "keys", "nodeschaos"], env=env,
                          capture_output=True, text=True, timeout=60, check=False)
    assert keys.returncode == 0, keys.stderr
    run_dir = root / "run"
    done = subprocess.run(
        [sys.executable, "-m", "mrss", "chaos", "nodeschaos", *CAMPAIGN, "--run-dir",
         str(run_dir), "--json"], capture_output=True, text=True, env=env, timeout=400,
        check=False)
    assert done.returncode in (0, 1, 4) and done.stdout.startswith("{"), \
        f"exit {done.returncode}\n{done.stderr}"
    yield done.returncode, load(run_dir / FILE_NAME), json.loads(done.stdout)


@pytest.mark.slow
@pytest.mark.timeout(450)
def test_a_node_cut_off_and_back_heals_to_the_same_state(campaign) -> None:  # type: ignore[no-untyped-def]
    code, h, report = campaign
    assert h.campaign["nodes"] == {"home": "base", "peers": ["field"]}
    assert [(f.kind, f.target, f.ok) for f in h.faults] == [
        ("node_partition", "field", True), ("node_partition", "field", True),
        ("node_loss", "field", True), ("node_delay", "field", True)], h.faults
    assert len(h.heals) == 4
    # every byte between the nodes went through the relays (node_delay), both ways
    relayed = h.end["relays"]["node field"]
    assert relayed["out_connections"] >= 1 and relayed["in_connections"] >= 1, relayed
    assert relayed["out_bytes"] > 0 and relayed["in_bytes"] > 0, relayed
    assert relayed["out_held"] > 0 and relayed["in_held"] > 0, relayed  # the delay
    states = [(e.t, e.body["available"], str(e.body.get("reason", "")))
              for e in h.of_kind("robot.state") if e.body.get("robot") == "ugv1"]
    for fault in (f for f in h.faults if f.kind == "node_partition"):
        healed = min(x.t for x in h.heals if x.t >= fault.t and x.kind == fault.kind)
        # down during the partition: seen going down in it, or already down when it began
        # (the loss before it may have cut the heartbeats already)
        before = [(up, why) for t, up, why in states if t <= fault.t]
        lost = [t for t, up, why in states if fault.t <= t <= healed + 1.0 and not up
                and why.startswith("node down")]
        if before and not before[-1][0] and before[-1][1].startswith("node down"):
            lost.append(fault.t)
        assert lost, f"ugv1 not lost during the partition at {fault.t:.3f}s: {states}"
        assert any(up for t, up, _ in states if t > lost[0]), \
            f"ugv1 not available again after the partition at {fault.t:.1f}s: {states}"
    ends = {str(e.body["uuid"]): e.body for e in h.of_kind("action.status")
            if e.body["state"] in ("succeeded", "failed", "cancelled")}
    failed = [b for b in ends.values() if b["state"] == "failed"]
    assert failed, "no action was caught by a partition (nothing was tested)"
    assert {b["cause"] for b in failed} == {"node_down"}, failed
    assert h.journal is not None
    assert {a.state for a in h.journal.actions} <= {"succeeded", "failed"}  # none stuck
    goals_failed = {b["goal"] for b in failed}
    succeeded = {b["goal"] for b in ends.values() if b["state"] == "succeeded"}
    assert goals_failed <= succeeded, "a patrol that failed with node_down was not re-run"
    verdict = check(h, Bounds(latch=10.0, cancel=10.0, converge=30.0))
    assert verdict.missing == []
    assert verdict.judgement(Invariant.HEALED) is Judgement.HOLDS
    assert verdict.judgement(Invariant.NO_ROBOT_STUCK) is Judgement.HOLDS
    assert verdict.outcome is Outcome.HOLDS, text(summary(h, verdict))
    assert code == 0, report
