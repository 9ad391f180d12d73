"""A short seeded campaign on a fleet with tasks addressed to a role (the CI form).

`python -m mrss chaos fleetloss` runs tests/chaos/projects/fleetloss: two simulated UAVs
(`mrss sim uav` processes over MAVLink, each behind a relay), the RCL, the reasoner,
whose agent asks for every sweep by role (`sweep(any([uav, camera], at(Lat, Lon)), G,
N)`), and an operator who asks for a sweep every ~3 s. One fault: `robot_loss`, which
waits until its robot runs a sweep and then cuts its link for good. About 45 s.

It checks that the loss came mid-task and what the RCL did about it: the lost robot's
sweep went back to allocation once its link timed out and was awarded to the other UAV,
which went on from the strip the first one had reached (and, if the campaign lasted
long enough, finished it: whether it did is the machine's pace); and that the
two task invariants judged that and hold: never-two-holders over every award, and
award-bounded over the wait that began with the loss (another capable UAV could take
the task while it waited), not vacuously. The whole verdict holds.
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
from mrss.chaos.tasks import lives, ready_times

PROJECTS = Path(__file__).resolve().parent / "projects"
CAMPAIGN = ["--faults", "1", "--seed", "2", "--kinds", "robot_loss", "--interval", "3..4",
            "--operator-every", "3", "--warmup", "3", "--latch-bound", "10",
            "--cancel-bound", "10", "--converge-bound", "30"]


@pytest.fixture(scope="module")
def campaign(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[int, History]]:
    run_dir = tmp_path_factory.mktemp("fleetchaos") / "run"
    env = dict(os.environ, MRSS_PROJECTS=str(PROJECTS))
    done = subprocess.run(
        [sys.executable, "-m", "mrss", "chaos", "fleetloss", *CAMPAIGN, "--run-dir",
         str(run_dir), "--json"], capture_output=True, text=True, env=env, timeout=300,
        check=False)
    assert done.returncode in (0, 1, 4) and done.stdout.startswith("{"), \
        f"exit {done.returncode}\n{done.stderr}"
    yield done.returncode, load(run_dir / FILE_NAME)


def test_the_documented_fleet_campaign_is_this_one() -> None:
    doc = (Path(__file__).resolve().parents[2] / "docs" / "chaos.md").read_text()
    assert f"mrss chaos fleetloss {' '.join(CAMPAIGN)}\n" in doc


@pytest.mark.slow
@pytest.mark.timeout(360)
def test_a_robot_lost_mid_task_hands_its_task_on_and_the_task_invariants_hold(
        campaign: tuple[int, History]) -> None:
    code, h = campaign
    [loss] = h.faults
    assert (loss.kind, loss.ok) == ("robot_loss", True)
    assert loss.holding, "the robot was lost while it ran no task"
    other = ({"uav1", "uav2"} - {loss.target}).pop()
    task = loss.holding[0]
    awards = [e.body for e in h.of_kind("action.allocation")
              if e.body["uuid"] == task and e.body["state"] == "awarded"]
    assert [a["robot"] for a in awards] == [loss.target, other]
    assert awards[1]["why"].startswith(f"reassigned from {loss.target} (lost)")
    seen = [e.body for e in h.of_kind("action.status") if e.body["uuid"] == task]
    released = next(s for s in seen if s["state"] == "pending" and not s["robot"]
                    and s["reason"].startswith("reassigning"))
    assert released["reason"].startswith(f"reassigning: robot {loss.target} unreachable")
    resumed = next(s for s in seen if s["progress"].get("by") == other)
    assert resumed["progress"]["first"] == released["progress"].get("step", 0)
    taken = next(i for i, s in enumerate(seen) if s["robot"] == other)
    after = seen[taken:]  # from then on never the lost robot's again, never failed
    assert {s["robot"] for s in after} == {other}
    assert {s["state"] for s in after} <= {"pending", "running", "succeeded"}
    assert all(not s["robot"] for s in seen[seen.index(released):taken])  # nobody's between

    verdict = check(h, Bounds(latch=10.0, cancel=10.0, converge=30.0))
    report = text(summary(h, verdict))
    for invariant in (Invariant.NEVER_TWO_HOLDERS, Invariant.AWARD_BOUNDED, Invariant.HEALED):
        assert verdict.judgement(invariant) is Judgement.HOLDS, report
    # the wait that began with the loss was judged: the other UAV could take the task
    life = lives(h)[task]
    [(start, stop, how)] = [w for w in life.waits if w[0] == loss.t]
    assert how == f"awarded to {other}"
    assert any(a < stop and z > start for a, z in ready_times(h, {other}).get(other, []))
    assert h.campaign["award_bound"]["link_loss"] == 3.0  # the robots' heartbeat_timeout
    assert verdict.outcome is Outcome.HOLDS and code == 0, report
    assert json.dumps(summary(h, verdict))  # the report is plain data
