"""The action journal on disk: WAL, transitions in order, reload, teleop flags."""

from __future__ import annotations

import sqlite3
import threading
from pathlib import Path

import pytest

from mrss.actors.rcl.journal import ActionJournal
from mrss.api import Action, ActionState


def test_journal_keeps_transitions_and_reloads_open_actions(tmp_path: Path) -> None:
    path = tmp_path / "j.sqlite3"
    journal = ActionJournal(path)
    a = Action(uuid="a", name="cover", args=["uav1", "g", {"k": [1, 2]}], robot="uav1",
               goal="g", priority=2, literal="cover(uav1,g)")
    journal.record(a)
    a.transition(ActionState.RUNNING)
    journal.record(a)
    journal.save_progress("a", {"waypoint": 4})
    b = Action(uuid="b", name="photo", robot="uav1")
    b.transition(ActionState.FAILED, "rejected: bad")
    journal.record(b)
    c = Action(uuid="c", name="cover", robot="ugv1")
    c.transition(ActionState.SUSPENDED, "teleop")
    journal.record(c, suspended_by="teleop")
    journal.set_teleop("ugv1", True)
    journal.set_teleop("uav1", True)
    journal.set_teleop("uav1", False)
    journal.close()

    reopened = ActionJournal(path)
    try:
        opened = reopened.open_actions()
        assert [e.action.uuid for e in opened] == ["a", "c"]
        restored, by, requester = opened[0]
        assert requester == ("", 0)
        assert restored == Action(uuid="a", name="cover", args=["uav1", "g", {"k": [1, 2]}],
                                  robot="uav1", goal="g", priority=2, state=ActionState.RUNNING,
                                  progress={"waypoint": 4}, literal="cover(uav1,g)")
        assert by == "" and opened[1].suspended_by == "teleop"
        assert reopened.transitions("a") == [(ActionState.PENDING, ""),
                                             (ActionState.RUNNING, "")]
        got = reopened.get("b")
        assert got is not None and got.action.reason == "rejected: bad"
        assert reopened.get("zzz") is None
        assert reopened.teleop_robots() == {"ugv1"}
    finally:
        reopened.close()


def test_journal_uses_wal_and_commits_each_record(tmp_path: Path) -> None:
    path = tmp_path / "j.sqlite3"
    journal = ActionJournal(path)
    try:
        journal.record(Action(uuid="a", name="n", robot="r"))
        other = sqlite3.connect(str(path))
        try:
            assert other.execute("PRAGMA journal_mode").fetchone()[0] == "wal"
            assert other.execute("SELECT state FROM actions").fetchall() == [("pending",)]
        finally:
            other.close()
    finally:
        journal.close()


def test_compaction_drops_old_terminal_actions_but_keeps_the_newest_and_open_ones(
        tmp_path: Path) -> None:
    now = [0.0]
    journal = ActionJournal(tmp_path / "j.sqlite3", clock=lambda: now[0])
    try:
        for i in range(10):  # ended at t = 0..9
            now[0] = float(i)
            a = Action(uuid=f"old{i}", name="noop", robot="ugv1")
            journal.record(a)
            a.transition(ActionState.SUCCEEDED)
            journal.record(a)
        now[0] = 1.0
        journal.record(Action(uuid="open", name="noop", robot="ugv1"))  # never ends
        journal.add_control("ugv1", "open", "{}")
        journal.add_control("ugv1", "old0", "{}")  # for an action that ended
        now[0] = 100.0
        assert journal.compaction() == (0, None)  # nothing dropped yet
        assert journal.compact(keep_seconds=95.0, keep_last=3) == 5  # t < 5 are too old
        assert journal.compaction() == (5, 5.0)  # what went, and the watermark
        assert journal.get("old4") is None and journal.transitions("old4") == []
        assert journal.get("old5") is not None  # younger than 95 s
        assert [e.action.uuid for e in journal.open_actions()] == ["open"]
        assert [u for _, u, _ in journal.pending_controls("ugv1")] == ["open"]
        now[0] = 1000.0  # everything ended is old now: the newest three stay
        assert journal.compact(keep_seconds=95.0, keep_last=3) == 2
        kept = [f"old{i}" for i in range(10) if journal.get(f"old{i}") is not None]
        assert kept == ["old7", "old8", "old9"]
        assert journal.compaction() == (7, 7.0)  # the newest kept one's time: none older
        assert journal.transitions("old9") == [(ActionState.PENDING, ""),
                                               (ActionState.SUCCEEDED, "")]
        assert journal.get("open") is not None
        assert journal.compact(keep_seconds=0.0, keep_last=0) == 3
        assert journal.compact(keep_seconds=0.0, keep_last=0) == 0  # dropped nothing:
        assert journal.compaction() == (10, 1000.0)  # the record stays as it was
    finally:
        journal.close()
    reopened = ActionJournal(tmp_path / "j.sqlite3")
    try:
        assert reopened.compaction() == (10, 1000.0)  # kept across a restart
    finally:
        journal.close()


def test_a_write_the_disk_refuses_for_a_while_waits_and_then_is_committed(
        tmp_path: Path) -> None:
    journal = ActionJournal(tmp_path / "j.sqlite3", write_patience=30.0)
    refused = threading.Event()
    journal._db.execute("PRAGMA query_only=ON")  # every write refused, as on a full disk
    original = journal._record

    def record(*args: object) -> int:
        try:
            return original(*args)  # type: ignore[arg-type]
        except sqlite3.OperationalError:
            refused.set()
            raise
    journal._record = record  # type: ignore[method-assign]
    writer = threading.Thread(target=journal.record, args=(Action(uuid="a1", name="go"),))
    writer.start()
    assert refused.wait(10)  # it was refused at least once ...
    journal._db.execute("PRAGMA query_only=OFF")  # ... the disk has room again
    writer.join(timeout=30)
    assert not writer.is_alive()
    entry = journal.get("a1")
    assert entry is not None and entry.action.state is ActionState.PENDING
    journal.close()


def test_a_write_refused_past_the_patience_raises_the_disk_error_and_the_journal_goes_on(
        tmp_path: Path) -> None:
    journal = ActionJournal(tmp_path / "j.sqlite3", write_patience=0.2)
    journal._db.execute("PRAGMA query_only=ON")
    with pytest.raises(sqlite3.OperationalError, match="readonly"):  # not "cannot rollback"
        journal.record(Action(uuid="a1", name="go"))
    journal._db.execute("PRAGMA query_only=OFF")
    journal.record(Action(uuid="a2", name="go"))
    assert journal.get("a1") is None and journal.get("a2") is not None
    journal.close()
