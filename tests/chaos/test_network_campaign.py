"""A short seeded campaign of network faults on the wildfire project (the CI form).

`python -m mrss chaos wildfire --kinds delay,loss,reorder,partition` as its own process,
with the simulators 20 times faster: relays stand in uav1's MAVLink link (UDP) and in
ugv1's connection to the broker (TCP); four faults on them, operator traffic every ~3 s.
The relays' counts show real traffic was delayed, dropped or cut; the campaign holds
every invariant, no-robot-stuck and heals-to-same-state among them.

A node fault asked for by name on a project that runs on one host is refused, with why.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from mrss.chaos.checker import Bounds, Invariant, Judgement, Outcome, check
from mrss.chaos.history import FILE_NAME, History, load
from mrss.chaos.report import summary, text

PROJECTS = Path(__file__).resolve().parents[2] / "projects"
CAMPAIGN = ["--faults", "4", "--seed", "3", "--kinds", "delay,loss,reorder,partition",
            "--interval", "3..4", "--duration", "2..3", "--operator-every", "3",
            "--warmup", "2", "--latch-bound", "10", "--cancel-bound", "10",
            "--converge-bound", "30"]
ENV = dict(os.environ, MRSS_PROJECTS=str(PROJECTS), MRSS_SIM_SPEEDUP="20")


@pytest.fixture(scope="module")
def campaign(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[int, History, dict]]:  # type: ignore[type-arg]
    run_dir = tmp_path_factory.mktemp("netchaos") / "run"
    done = subprocess.run(
        [sys.executable, "-m", "mrss", "chaos", "wildfire", *CAMPAIGN, "--run-dir",
         str(run_dir), "--json"], capture_output=True, text=True, env=ENV, timeout=400,
        check=False)
    assert done.returncode in (0, 1, 4) and done.stdout.startswith("{"), \
        f"exit {done.returncode}\n{done.stderr}"
    yield done.returncode, load(run_dir / FILE_NAME), json.loads(done.stdout)


@pytest.mark.slow
@pytest.mark.timeout(450)
def test_network_faults_hit_real_traffic_and_the_campaign_holds(campaign) -> None:  # type: ignore[no-untyped-def]
    code, h, report = campaign
    assert h.campaign["relayed"] == {"uav1": "mavlink", "uav2": "mavlink", "uav3": "mavlink",
                                     "ugv1": "mqtt", "ugv2": "mqtt"}  # the fleet
    assert [f.ok for f in h.faults] == [True] * 4, h.faults
    assert {f.kind for f in h.faults} <= {"delay", "loss", "reorder", "partition"}
    assert len(h.heals) == 4
    relays = h.end["relays"]
    assert relays["uav1"]["passed"] > 0 and relays["ugv1"]["bytes"] > 0
    if any(f.kind in ("loss", "partition") and f.target == "uav1" for f in h.faults):
        assert relays["uav1"].get("dropped", 0) > 0
    verdict = check(h, Bounds(latch=10.0, cancel=10.0, converge=30.0))
    assert verdict.missing == []
    assert verdict.judgement(Invariant.NO_ROBOT_STUCK) is Judgement.HOLDS  # cover ran
    assert verdict.judgement(Invariant.HEALED) is Judgement.HOLDS
    assert verdict.outcome is Outcome.HOLDS, text(summary(h, verdict))
    assert code == 0 and report["relays"] == relays


def test_a_node_fault_asked_for_by_name_on_one_host_is_refused_with_why() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "mrss", "chaos", "wildfire", "--kinds", "partition,node_loss",
         "--faults", "1"], capture_output=True, text=True, env=ENV, timeout=60, check=False)
    assert done.returncode == 2, done.stderr
    assert "--kinds node_loss: cannot be injected here: the project runs on one host" \
        in done.stderr
