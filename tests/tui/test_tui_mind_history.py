"""The mind inspector's ring buffer: kept snapshots, a pinned cursor, belief diffs."""

from __future__ import annotations

from mrss.messages import MindSnapshot
from mrss.tui.models.mind_history import MindHistory


def snap(*beliefs: str) -> MindSnapshot:
    return MindSnapshot(agent="r", beliefs=list(beliefs), intentions=[], events=[])


def test_history_keeps_changes_steps_freezes_and_diffs() -> None:
    history = MindHistory(limit=3)
    assert history.add(snap("a"), 1.0, 1)
    assert not history.add(snap("a"), 2.0, 1)  # the same again: not a new entry
    assert history.add(snap("a"), 3.0, 2)  # the same from a new incarnation: kept
    assert history.add(snap("a", "b"), 4.0, 2)
    assert [e.ts for e in history.entries] == [1.0, 3.0, 4.0] and history.live
    assert history.diff() == (["b"], [])
    assert history.back() and history.current().ts == 3.0 and not history.live
    history.add(snap("b"), 5.0, 2)  # the ring drops ts 1.0; the cursor stays on 3.0
    assert history.current().ts == 3.0 and history.diff() == ([], [])
    assert history.back() is False  # 3.0 is the oldest kept now
    assert history.forward() and history.current().ts == 4.0
    history.add(snap("c"), 6.0, 2)  # drops 3.0; 4.0 still shown, now the oldest
    assert history.current().ts == 4.0 and history.diff() == ([], [])
    history.add(snap("d"), 7.0, 2)  # the one shown falls out: the oldest kept is shown
    assert history.current().ts == 5.0 and history.diff() == ([], [])  # the oldest now
    assert history.diff(history.entries[-1]) == (["d"], ["c"])
    history.follow()
    assert history.live and history.current().ts == 7.0
    history.freeze()
    history.add(snap("e"), 8.0, 2)
    assert history.current().ts == 7.0 and history.position() == 1
