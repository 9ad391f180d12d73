"""The parts of `mrss chaos` around the checker: the plan, the traffic, the history file,
the report, and `mrss chaos --check` on a recorded file."""

from __future__ import annotations

import json
import random
from pathlib import Path

import pytest

from mrss.chaos.campaign import CampaignError, parse_kinds, parse_range, plan
from mrss.chaos.checker import Invariant, check
from mrss.chaos.faults import FaultKind, targets
from mrss.chaos.history import HistoryError, HistoryWriter, load, parse
from mrss.chaos.report import summary, text
from mrss.chaos.runner import failed_goal_functors
from mrss.chaos.traffic import Intent, load_traffic, step_from
from mrss.cli import main
from mrss.config.loader import load_project
from mrss.errors import ConfigError
from tests.chaos.histories import edit, healthy, operator

WILDFIRE = Path(__file__).resolve().parents[2] / "projects" / "wildfire"
TARGETS = {FaultKind.KILL: ["bus", "rcl"], FaultKind.HANG: ["rcl"], FaultKind.LINK: ["sim"],
           FaultKind.BROKER: []}


def test_the_same_seed_plans_the_same_faults_and_another_seed_others() -> None:
    kinds = [FaultKind.KILL, FaultKind.HANG, FaultKind.LINK, FaultKind.BROKER]
    first = plan(7, 20, kinds, TARGETS, (3.0, 6.0), (2.0, 8.0))
    assert first == plan(7, 20, kinds, TARGETS, (3.0, 6.0), (2.0, 8.0))
    assert first != plan(8, 20, kinds, TARGETS, (3.0, 6.0), (2.0, 8.0))
    assert FaultKind.BROKER not in {f.kind for f in first}  # no target in this project
    gaps = [b.at - a.at for a, b in zip(first, first[1:], strict=False)]
    assert all(2.99 <= g <= 6.01 for g in gaps)
    assert all((2.0 <= f.duration <= 8.0) if f.kind.timed else f.duration == 0.0
               for f in first)


def test_a_plan_with_no_usable_kind_is_refused() -> None:
    with pytest.raises(CampaignError, match="has a target"):
        plan(1, 3, [FaultKind.BROKER], TARGETS, (1.0, 2.0), (1.0, 2.0))


def test_ranges_and_kinds_are_checked_with_the_option_named() -> None:
    assert parse_range("3..6", "--interval") == (3.0, 6.0)
    assert parse_range("4", "--interval") == (4.0, 4.0)
    with pytest.raises(CampaignError, match="--interval"):
        parse_range("6..3", "--interval")
    with pytest.raises(CampaignError, match="--duration"):
        parse_range("soon", "--duration")
    assert parse_kinds("kill, link") == [FaultKind.KILL, FaultKind.LINK]
    with pytest.raises(CampaignError, match="unknown fault kind 'nuke'"):
        parse_kinds("kill,nuke")


def test_wildfire_offers_a_target_for_every_fault_kind() -> None:
    found = targets(load_project("wildfire", WILDFIRE.parent))
    assert found[FaultKind.BLACKOUT] == ["bus"]
    assert found[FaultKind.BROKER] == ["broker"]
    assert found[FaultKind.LINK] == ["sim_uav", "sim_uav2", "sim_uav3", "sim_ugv", "sim_ugv2"]
    assert found[FaultKind.DISK_FULL] == ["rcl"]
    assert found[FaultKind.FORKSERVER] == ["forkserver"]
    assert "reasoner" in found[FaultKind.KILL]
    only = targets(load_project("wildfire", WILDFIRE.parent), only=["rcl", "nothing"])
    assert only[FaultKind.KILL] == ["rcl"] and only[FaultKind.HANG] == ["rcl"]


def test_wildfire_traffic_is_well_formed_and_pairs_every_teleop_on_with_off() -> None:
    traffic = load_traffic(WILDFIRE)
    assert traffic.mode_beliefs == {"teleop": "paused({robot},teleop)"}
    steps = [s for s, _ in zip(traffic.steps(3, 20.0), range(200), strict=False)]
    intents = {s.intent for s in steps}
    assert intents == set(Intent)
    modes = [s.on for s in steps if s.intent is Intent.MODE]
    assert modes[0::2] == [True] * len(modes[0::2]) and not any(modes[1::2])
    goals = [s.goal for s in steps if s.intent is Intent.GOAL]
    assert len(goals) == len(set(goals))
    assert steps == [s for s, _ in zip(traffic.steps(3, 20.0), range(200), strict=False)]


def test_the_campaign_knows_how_a_project_tells_the_operator_a_goal_failed() -> None:
    assert failed_goal_functors(load_project("wildfire", WILDFIRE.parent)) == ["failed_goal"]
    # A project without [operator.goals] failed: only replies count as telling.
    assert failed_goal_functors(load_project("amadee", WILDFIRE.parent)) == []


def test_a_bad_step_is_refused_with_the_key_and_what_was_expected() -> None:
    with pytest.raises(ConfigError, match="intent"):
        step_from({"intent": "dance", "topic": "t", "payload": {}}, "chaos.py step 1")
    with pytest.raises(ConfigError, match="expected a goal id"):
        step_from({"intent": "goal", "topic": "t", "payload": {}}, "chaos.py step 1")
    with pytest.raises(ConfigError, match="expected true or false"):
        step_from({"intent": "mode", "topic": "t", "payload": {}, "robot": "r",
                   "mode": "teleop", "on": "yes"}, "chaos.py step 1")


def test_a_project_without_chaos_py_has_no_traffic(tmp_path: Path) -> None:
    traffic = load_traffic(tmp_path)
    assert list(traffic.steps(1, 1.0)) == [] and traffic.reply_topics == ()


def test_a_history_written_record_by_record_reads_back_the_same(tmp_path: Path) -> None:
    path = tmp_path / "h.jsonl"
    writer = HistoryWriter(path)
    for record in healthy():
        writer.write(record.pop("type"), **record)
    writer.close()
    assert load(path) == parse(healthy())


def test_a_broken_history_file_names_its_line(tmp_path: Path) -> None:
    path = tmp_path / "h.jsonl"
    lines = [json.dumps(r) for r in healthy()]
    lines[3] = '{"type": "bus", "t": 1}'
    path.write_text("\n".join(lines))
    with pytest.raises(HistoryError, match=r"h.jsonl:4: bad record"):
        load(path)


def test_the_report_has_every_section_and_each_violation_with_evidence() -> None:
    history = parse(healthy() + [operator(20.0, "goal", "a2")])
    s = summary(history, check(history), "h.jsonl")
    assert s["faults_injected"] == {"kill": 1} and s["restarts"] == {"datalayer": 1}
    assert s["actions"] == {"succeeded": 2}  # cover and the sweep
    assert (s["goals_accepted"], s["goals_acted_on"], s["goals_reported_failed"]) == (2, 1, 0)
    assert s["goal_outcomes"]["dropped"] == 1 and s["converged_after"] == 25.0
    assert set(s["invariants"]) == {i.value for i in Invariant}
    report = text(s)
    for i in Invariant:
        assert i.value in report
    assert "- goal-handled a2" in report
    assert "  goal-handled                   FAILS: 1 violation(s)" in report
    assert report.endswith("verdict: FAILS: 1 invariant(s) violated, 1 violation(s) (exit 1)")


def test_restarts_are_the_roots_count_when_a_probe_got_the_tree() -> None:
    records = healthy()
    edit(records, "probe")["tree"]["children"][0]["restarts"] = 4  # rcl: events missed
    history = parse(records)
    assert summary(history, check(history))["restarts"] == {"rcl": 4, "datalayer": 1}
    no_tree = parse([r for r in healthy() if r["type"] != "probe"])
    assert summary(no_tree, check(no_tree))["restarts"] == {"datalayer": 1}


def write(path: Path, records: list[dict[str, object]]) -> Path:
    path.write_text("\n".join(json.dumps(r) for r in records) + "\n")
    return path


def test_mrss_chaos_check_exits_0_when_every_invariant_holds(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["chaos", "--check", str(write(tmp_path / "h.jsonl", healthy()))]) == 0
    assert capsys.readouterr().out.endswith("verdict: holds: every invariant holds (exit 0)\n")


def test_mrss_chaos_check_exits_1_on_a_violation_and_2_on_a_bad_file(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = write(tmp_path / "bad.jsonl", healthy() + [operator(20.0, "goal", "a2")])
    assert main(["chaos", "--check", str(bad), "--json"]) == 1
    out = json.loads(capsys.readouterr().out)
    assert out["invariants"]["goal-handled"] == {"judgement": "fails", "violations": 1,
                                                 "why": ""}
    assert out["verdict"] == "fails" and out["missing"] == []
    assert main(["chaos", "--check", str(tmp_path / "missing.jsonl")]) == 2
    assert "cannot read" in capsys.readouterr().err
    assert main(["chaos"]) == 2


def test_random_durations_stay_inside_their_range() -> None:
    rng = random.Random(0)
    kinds = [FaultKind.HANG]
    for seed in (rng.randrange(1000) for _ in range(5)):
        assert all(1.0 <= f.duration <= 1.5 for f in plan(
            seed, 10, kinds, {FaultKind.HANG: ["x"]}, (1.0, 1.0), (1.0, 1.5)))
