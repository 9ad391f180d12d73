"""A short seeded campaign on the wildfire project through `mrss chaos` (the CI campaign).

One campaign runs for the module: `python -m mrss chaos wildfire --json` as its own
process, with the simulators 20 times faster than real time, three faults (kills, hangs,
a bus blackout, a link loss), operator traffic every ~3 s. About half a minute: 2 s of
warm-up, a fault every 3-4 s (each over before the next begins: they last 2-3 s), then
the checker's latch and cancel bounds (10 s) of calm so that every rule can be judged.

`test_the_campaign_checks_a_real_history` holds whatever the system does: the faults were
really injected, actions really ran, the history file is complete (the checker finds
nothing missing, and the runner waited long enough for every rule to be judged), and
the checker's verdict (exit code, report) is the one `--check` finds again offline.
`test_the_campaign_holds` is the strict one: the verdict is "holds" (exit 0).
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
CAMPAIGN = ["--faults", "3", "--seed", "11", "--kinds", "kill,hang,blackout,link",
            "--interval", "3..4", "--duration", "2..3", "--operator-every", "3",
            "--warmup", "2", "--latch-bound", "10", "--cancel-bound", "10",
            "--converge-bound", "30"]


class Campaign:
    def __init__(self, run_dir: Path, done: subprocess.CompletedProcess[str]) -> None:
        self.run_dir, self.code, self.stderr = run_dir, done.returncode, done.stderr
        self.summary = json.loads(done.stdout) if done.stdout.strip() else {}
        self.history: History = load(run_dir / FILE_NAME)


@pytest.fixture(scope="module")
def campaign(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Campaign]:
    run_dir = tmp_path_factory.mktemp("chaos") / "run"
    env = dict(os.environ, MRSS_PROJECTS=str(PROJECTS), MRSS_SIM_SPEEDUP="20")
    done = subprocess.run(
        [sys.executable, "-m", "mrss", "chaos", "wildfire", *CAMPAIGN, "--run-dir",
         str(run_dir), "--json"], capture_output=True, text=True, env=env, timeout=400,
        check=False)
    assert done.returncode in (0, 1, 4) and done.stdout.startswith("{"), \
        f"exit {done.returncode}\n{done.stderr}"
    yield Campaign(run_dir, done)


@pytest.mark.slow
@pytest.mark.timeout(450)
def test_the_campaign_checks_a_real_history(campaign: Campaign) -> None:
    h = campaign.history
    assert h.campaign["project"] == "wildfire" and h.campaign["seed"] == 11
    assert len(h.campaign["planned"]) == 3
    assert [f.ok for f in h.faults] == [True, True, True], h.faults
    assert len(h.heals) == sum(1 for f in h.faults if f.duration > 0)
    assert h.of_kind("action.request") and h.of_kind("action.status")
    assert h.journal is not None and not h.journal.error and h.journal.actions
    assert [o for o in h.operator if o.ok and o.intent == "goal"]
    assert h.probes and h.probes[-1].t >= h.faults_ended_at
    assert h.loglines and h.end["faults_ended"] == h.faults_ended_at
    assert h.log is not None and h.log.lines == len(h.loglines) and not h.log.error

    verdict = check(h, _bounds())
    assert verdict.missing == []
    assert Judgement.INCOMPLETE not in {verdict.judgement(i) for i in Invariant}
    assert campaign.code == verdict.outcome.exit_code, campaign.stderr
    again = summary(h, verdict, str(campaign.run_dir / FILE_NAME))
    assert campaign.summary == again
    for key in ("faults_injected", "restarts", "actions", "goals_accepted", "goals_acted_on",
                "goals_reported_failed", "goal_outcomes", "converged_after", "invariants",
                "violations", "missing", "verdict"):
        assert key in again
    assert set(again["invariants"]) == {i.value for i in Invariant}
    assert sum(again["faults_injected"].values()) == 3
    assert sum(again["actions"].values()) == len(h.journal.actions)


@pytest.mark.slow
@pytest.mark.timeout(450)
def test_the_campaign_holds(campaign: Campaign) -> None:
    verdict = check(campaign.history, _bounds())
    assert verdict.outcome is Outcome.HOLDS, text(summary(campaign.history, verdict))
    assert campaign.code == 0


def _bounds() -> Bounds:
    return Bounds(latch=10.0, cancel=10.0, converge=30.0)
