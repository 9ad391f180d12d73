"""The action journal on disk: WAL, transitions in order, reload, teleop flags."""

from __future__ import annotations

import sqlite3
from pathlib import Path

from mrss.actors.journal import ActionJournal
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
