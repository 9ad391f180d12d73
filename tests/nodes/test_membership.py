"""Node membership (mrss.supervision.nodes): the state table driven by hand, with fake
clocks: silence, return, a clock far off, two processes as one node, an impostor."""

from __future__ import annotations

from mrss.supervision.nodes import TRANSITIONS, Membership, NodeCause, NodeState


class Clocks:
    def __init__(self) -> None:
        self.mono = 100.0
        self.wall = 1_700_000_000.0


def _members(c: Clocks) -> Membership:
    return Membership("base", ["base", "field", "relay"], interval=0.5, misses=4,
                      max_skew=5.0, clock=lambda: c.mono, wall=lambda: c.wall)


def test_every_state_and_cause_has_a_next_state() -> None:
    assert {(s, c) for s in NodeState for c in NodeCause} == set(TRANSITIONS)


def test_silence_then_return() -> None:
    c = Clocks()
    m = _members(c)
    assert set(m.states()) == {"field", "relay"}  # not itself
    assert m.beat("field", "field", "b1", c.wall)[0].after is NodeState.UP
    c.mono += 1.9
    assert m.tick() == []
    c.mono += 0.2  # 2.1 s > 0.5 * 4
    moved = m.tick()
    assert [(t.node, t.after, t.cause, t.event) for t in moved] == [
        ("field", NodeState.DOWN, NodeCause.SILENT, "node_down"),
        ("relay", NodeState.DOWN, NodeCause.SILENT, "node_down")]
    assert "since start" in moved[1].reason and "for 2.1 s" in moved[0].reason
    assert m.tick() == []  # no repeats from tick
    assert [t.node for t in m.lost()] == ["field", "relay"]
    back = m.beat("field", "field", "b2", c.wall)  # a restarted process: not a duplicate
    assert [(t.after, t.event) for t in back] == [(NodeState.UP, "node_up")]
    assert m.admits("field") and not m.admits("stranger")


def test_clock_far_off_is_refused_until_fixed() -> None:
    c = Clocks()
    m = _members(c)
    moved = m.beat("field", "field", "b1", c.wall + 3600)
    assert moved[0].after is NodeState.REFUSED and moved[0].cause is NodeCause.CLOCK_SKEW
    assert "3600.0 s ahead of ours" in moved[0].reason
    assert not m.admits("field")
    assert m.beat("field", "field", "b1", c.wall - 60) == []  # still refused: no news
    assert not m.admits("field")
    assert m.beat("field", "field", "b1", c.wall + 1)[0].after is NodeState.UP


def test_two_processes_as_one_node_are_refused_until_one_is_left() -> None:
    c = Clocks()
    m = _members(c)
    m.beat("field", "field", "old", c.wall)
    c.mono += 0.1
    assert m.beat("field", "field", "new", c.wall) == []  # could be a restart
    c.mono += 0.1
    moved = m.beat("field", "field", "old", c.wall)  # the old one still beats: two
    assert moved[0].cause is NodeCause.DUPLICATE and "new, old" in moved[0].reason
    assert not m.admits("field")
    for _ in range(5):  # only the new one from now on
        c.mono += 0.5
        m.beat("field", "field", "new", c.wall)
        moved = m.tick() or moved
    assert m.state("field") is NodeState.UP


def test_a_key_naming_another_node_is_an_impostor() -> None:
    c = Clocks()
    m = _members(c)
    moved = m.beat("field", "relay", "b1", c.wall)
    assert moved[0].node == "field" and moved[0].cause is NodeCause.IMPOSTOR
    assert m.state("relay") is NodeState.WAITING
