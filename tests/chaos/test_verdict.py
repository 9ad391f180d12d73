"""The verdict: a history must be complete to hold, an invariant with nothing to check is
vacuous, and `mrss chaos --check` exits 0 / 1 / 4 for holds / fails / incomplete."""

from __future__ import annotations

import json
import sqlite3
from collections.abc import Callable
from pathlib import Path

import pytest

from mrss.actors.rcl.action import Action
from mrss.actors.rcl.journal import ActionJournal
from mrss.chaos.checker import Bounds, GoalOutcome, Invariant, Judgement, Outcome, Verdict, check
from mrss.chaos.history import FILE_NAME, HistoryWriter, load, parse
from mrss.chaos.recorder import Recorder
from mrss.chaos.report import summary, text
from mrss.chaos.runner import settled
from mrss.cli import main
from mrss.messages import ActionState
from tests.chaos.histories import U1, Record, edit, healthy, operator, probe, status

NEEDS_JOURNAL = {Invariant.LATCH_RELEASED, Invariant.GOAL_HANDLED,
                 Invariant.NO_COMMAND_AFTER_CANCEL}


def verdict(records: list[Record]) -> Verdict:
    return check(parse(records), Bounds(latch=15.0, cancel=15.0, converge=60.0))


def without(*types: str) -> list[Record]:
    return [r for r in healthy() if r["type"] not in types]


def judgements(v: Verdict) -> dict[Invariant, Judgement]:
    return {i: v.judgement(i) for i in Invariant}


def write(path: Path, records: list[Record]) -> Path:
    path.write_text("\n".join(json.dumps(r) for r in records) + "\n")
    return path


def test_a_complete_healthy_history_holds_with_nothing_vacuous() -> None:
    v = verdict(healthy())
    assert v.missing == []
    assert set(judgements(v).values()) == {Judgement.HOLDS}
    assert v.outcome is Outcome.HOLDS and v.outcome.exit_code == 0


def test_an_empty_history_is_incomplete_and_names_everything_it_lacks() -> None:
    """The issue's case: a campaign record alone (3 faults planned) once gave "every
    invariant holds" and exit 0."""
    v = verdict([{"type": "campaign", "t": 0.0, "project": "test", "seed": 1,
                  "planned": [{}, {}, {}], "operator": False}])
    assert v.violations == []
    assert v.outcome is Outcome.INCOMPLETE and v.outcome.exit_code == 4
    assert len(v.missing) == 5
    for words in ("no journal record", "no end record", "0 of the 3 planned faults",
                  "no operator goal accepted", "chaos.py", "no log record"):
        assert any(words in m for m in v.missing), (words, v.missing)
    assert Judgement.HOLDS not in judgements(v).values()


@pytest.mark.parametrize(("cut", "lacks"), [
    (lambda r: [x for x in r if x["type"] != "end"], "no end record"),
    (lambda r: [x for x in r if x["type"] != "log"], "no log record"),
    (lambda r: [x if x["type"] != "fault" else {**x, "ok": False, "error": "gone"}
                for x in r], "0 of the 1 planned faults injected"),
    (lambda r: [x if x["type"] != "operator" or x["intent"] != "goal" else {**x, "ok": False}
                for x in r], "no operator goal accepted by the broker"),
], ids=["no end", "no log record", "fault not injected", "no goal accepted"])
def test_a_history_missing_one_part_is_incomplete(
        cut: Callable[[list[Record]], list[Record]], lacks: str) -> None:
    v = verdict(cut(healthy()))
    assert v.violations == []
    assert len(v.missing) == 1 and v.missing[0].startswith(lacks), v.missing
    assert v.outcome is Outcome.INCOMPLETE


def test_a_history_without_the_journal_is_incomplete_and_asserts_nothing_it_needs() -> None:
    v = verdict(without("journal"))
    assert v.outcome is Outcome.INCOMPLETE
    assert v.missing == ["no journal record: the RCL journal was not read"]
    judged = judgements(v)
    assert all(judged[i] is Judgement.INCOMPLETE for i in NEEDS_JOURNAL)
    # a1's action succeeded, which only the journal says: it is not called dropped
    assert v.of(Invariant.GOAL_HANDLED) == []


def test_an_unreadable_journal_is_incomplete() -> None:
    records = healthy()
    edit(records, "journal").update(actions=[], transitions=[], error="database is locked")
    v = verdict(records)
    assert v.missing == ["the RCL journal could not be read: database is locked"]
    assert v.outcome is Outcome.INCOMPLETE


def test_a_violation_the_bus_shows_fails_even_without_the_journal() -> None:
    v = verdict(without("journal") + [status(11.0, U1, "failed")])
    assert v.judgement(Invariant.ONE_TERMINAL) is Judgement.FAILS
    assert v.outcome is Outcome.FAILS


def test_an_unreadable_log_is_incomplete_and_no_latch_is_called_unreleased() -> None:
    """Without the log no release is seen: that is no evidence of a stuck latch."""
    records = [r for r in healthy() if r["type"] != "logline"]
    edit(records, "log").update(lines=0, error="run/mrss.log: Permission denied")
    v = verdict(records)
    assert v.missing == ["the run's log could not be read: run/mrss.log: Permission denied"]
    assert v.judgement(Invariant.LATCH_RELEASED) is Judgement.INCOMPLETE
    assert v.judgement(Invariant.NO_COMMAND_AFTER_CANCEL) is Judgement.INCOMPLETE
    assert v.outcome is Outcome.INCOMPLETE


def test_an_invariant_with_nothing_to_check_is_vacuous_and_the_campaign_may_hold() -> None:
    records = [r for r in healthy() if r["type"] != "operator" or r["intent"] != "mode"]
    v = verdict(records)
    assert v.judgement(Invariant.MODE_CONSISTENT) is Judgement.VACUOUS
    assert v.why(Invariant.MODE_CONSISTENT) == "no mode switch accepted"
    assert v.outcome is Outcome.HOLDS
    report = text(summary(parse(records), v))
    assert "  mode-consistent                vacuous: no mode switch accepted" in report
    assert report.endswith("verdict: holds: every invariant holds (1 vacuous: "
                           "mode-consistent) (exit 0)")


def test_a_campaign_whose_every_invariant_is_vacuous_fails() -> None:
    records: list[Record] = [
        {"type": "campaign", "t": 0.0, "project": "test", "seed": 1, "planned": []},
        probe(6.0),
        {"type": "journal", "t": 30.0, "actions": [], "transitions": [], "teleop": {}},
        {"type": "log", "t": 30.5, "file": "run/mrss.log", "lines": 0},
        {"type": "end", "t": 31.0, "faults_ended": 5.0, "exit_code": 0}]
    v = verdict(records)
    assert set(judgements(v).values()) == {Judgement.VACUOUS}
    assert v.outcome is Outcome.FAILS
    assert "verdict: FAILS: every invariant is vacuous" in text(summary(parse(records), v))


def test_mode_consistency_too_soon_after_the_last_switch_is_undetermined() -> None:
    """Once it returned nothing, i.e. "ok"; the runner now waits for the calm."""
    records = healthy() + [operator(30.0, "mode", robot="ugv1", mode="teleop", on=True)]
    v = verdict(records)
    assert v.judgement(Invariant.MODE_CONSISTENT) is Judgement.INCOMPLETE
    assert v.why(Invariant.MODE_CONSISTENT).startswith(
        "undetermined: the history ends at 40.0s, 10.0s after the last fault or switch")
    assert v.outcome is Outcome.INCOMPLETE
    edit(records, "journal")["t"] = 46.0  # 16 s of calm: judged (nobody saw it on)
    assert verdict(records).judgement(Invariant.MODE_CONSISTENT) is Judgement.FAILS


def test_without_pending_beliefs_no_belief_holds_a_goal() -> None:
    """Once any belief naming the goal held it when the project declared none."""
    records = healthy() + [operator(20.0, "goal", "a2"),
                           probe(35.0, beliefs=["refused(a2,crew_safety)[source(self)]",
                                                "queued(uav1,a2,3,cover)[source(self)]"])]
    del records[0]["pending_beliefs"]
    v = verdict(records)
    assert v.goals["a2"] is GoalOutcome.DROPPED
    assert v.judgement(Invariant.GOAL_HANDLED) is Judgement.FAILS
    records[0]["pending_beliefs"] = ["queued"]
    assert verdict(records).goals["a2"] is GoalOutcome.HELD


def test_mrss_chaos_check_exits_4_on_an_incomplete_history(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = write(tmp_path / "h.jsonl", without("journal"))
    assert main(["chaos", "--check", str(path)]) == 4
    out = capsys.readouterr().out
    assert "the history is incomplete:\n  - no journal record" in out
    assert "  goal-handled                   INCOMPLETE: no journal record" in out
    assert out.rstrip().endswith("(exit 4)") and "verdict: INCOMPLETE" in out
    assert main(["chaos", "--check", str(path), "--json"]) == 4
    s = json.loads(capsys.readouterr().out)
    assert s["verdict"] == "incomplete" and s["missing"]
    assert s["invariants"]["latch-released"]["judgement"] == "incomplete"
    empty = write(tmp_path / "empty.jsonl", [healthy()[0]])
    assert main(["chaos", "--check", str(empty)]) == 4


def test_the_recorder_records_an_unreadable_log_and_journal_as_errors(tmp_path: Path) -> None:
    """A log it cannot read was once skipped without a word, and every log-based rule
    then passed with nothing to check."""
    (tmp_path / "mrss.log").mkdir()  # reading it fails (root reads any file)
    writer = HistoryWriter(tmp_path / FILE_NAME)
    writer.write("campaign", t=0.0, project="test", seed=1, planned=[])
    recorder = Recorder(tmp_path, writer, tmp_path / "no-such-journal.sqlite3")
    try:
        assert recorder.record_log({"reasoner"}) == 0
        recorder.record_journal()
    finally:
        recorder.close()
        writer.close()
    history = load(tmp_path / FILE_NAME)
    assert history.log is not None and "mrss.log" in history.log.error
    assert history.journal is not None and history.journal.error
    v = check(history)
    assert any("the run's log could not be read" in m for m in v.missing)
    assert any("the RCL journal could not be read" in m for m in v.missing)
    assert v.outcome is Outcome.INCOMPLETE


def test_the_recorder_counts_the_log_lines_it_kept(tmp_path: Path) -> None:
    (tmp_path / "mrss.log").write_text(
        "2026-01-01 10:00:00,000 reasoner[12] INFO action x done\n"
        "2026-01-01 10:00:00,100 datalayer[13] INFO not kept\n"
        "2026-01-01 10:00:00,200 datalayer[13] WARNING kept\n")
    writer = HistoryWriter(tmp_path / FILE_NAME)
    writer.write("campaign", t=0.0, project="test", seed=1, planned=[])
    recorder = Recorder(tmp_path, writer, tmp_path / "journal.sqlite3")
    try:
        assert recorder.record_log({"reasoner"}) == 2
    finally:
        recorder.close()
        writer.close()
    history = load(tmp_path / FILE_NAME)
    assert len(history.loglines) == 2
    assert history.log is not None and (history.log.lines, history.log.error) == (2, "")


def test_the_recorder_records_what_the_journals_compaction_dropped(tmp_path: Path) -> None:
    journal = ActionJournal(tmp_path / "journal.sqlite3")
    try:
        for uuid in ("a" * 32, "b" * 32, "c" * 32):
            action = Action(uuid=uuid, name="noop", robot="ugv1")
            journal.record(action)
            if uuid != "c" * 32:
                action.transition(ActionState.SUCCEEDED)
                journal.record(action)
        assert journal.compact(keep_seconds=0.0, keep_last=0) == 2
        dropped, before = journal.compaction()
    finally:
        journal.close()
    writer = HistoryWriter(tmp_path / FILE_NAME)
    writer.write("campaign", t=0.0, project="test", seed=1, planned=[])
    recorder = Recorder(tmp_path, writer, tmp_path / "journal.sqlite3")
    try:
        recorder.record_journal()
    finally:
        recorder.close()
        writer.close()
    history = load(tmp_path / FILE_NAME)
    assert history.journal is not None and not history.journal.error
    assert [a.uuid for a in history.journal.actions] == ["c" * 32]
    assert dropped == 2 and before is not None
    assert history.journal.compacted == 2
    assert history.journal.compacted_before == recorder.since_start(before)


def test_a_journal_from_before_compaction_was_recorded_reads_as_none_dropped(
        tmp_path: Path) -> None:
    with sqlite3.connect(tmp_path / "journal.sqlite3") as db:  # the tables of an old journal
        db.executescript("CREATE TABLE actions (uuid, name, robot, goal, state, reason, "
                         "requester, requester_inc, created);"
                         "CREATE TABLE transitions (seq, uuid, state, reason, ts);"
                         "CREATE TABLE robots (robot, teleop);")
    writer = HistoryWriter(tmp_path / FILE_NAME)
    writer.write("campaign", t=0.0, project="test", seed=1, planned=[])
    recorder = Recorder(tmp_path, writer, tmp_path / "journal.sqlite3")
    try:
        recorder.record_journal()
    finally:
        recorder.close()
        writer.close()
    journal = load(tmp_path / FILE_NAME).journal
    assert journal is not None and not journal.error
    assert (journal.compacted, journal.compacted_before) == (0, None)


def test_the_verdict_and_exit_codes_are_one_closed_set() -> None:
    assert {o: o.exit_code for o in Outcome} == {
        Outcome.HOLDS: 0, Outcome.FAILS: 1, Outcome.INCOMPLETE: 4}
    assert [j.value for j in Judgement] == ["holds", "fails", "incomplete", "vacuous"]


def test_the_runner_probes_until_the_calm_after_the_last_mode_switch() -> None:
    """mode-consistent is judged only `cancel` s after the later of the last fault and
    the last switch: the campaign must look that long, not just after the faults."""
    b = Bounds(latch=10.0, cancel=10.0, converge=30.0)
    assert not settled(25.0, True, faults_ended=14.0, calm_from=18.0, bounds=b)
    assert settled(28.0, True, faults_ended=14.0, calm_from=18.0, bounds=b)
    assert not settled(40.0, False, faults_ended=14.0, calm_from=18.0, bounds=b)
    assert settled(44.0, False, faults_ended=14.0, calm_from=18.0, bounds=b)
    assert not settled(44.0, False, faults_ended=14.0, calm_from=40.0, bounds=b)
