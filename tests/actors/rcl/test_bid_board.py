"""The bid board: robot actors' published states, and actions told to them not shown yet."""

from mrss.actors.rcl.allocation.bids import Work
from mrss.actors.rcl.allocation.board import BidBoard, BidState

A = Work("a", 3, 0.0)


def test_a_robot_without_a_published_state_does_not_bid() -> None:
    board = BidBoard()
    assert board.state("uav1") is None
    board.started("uav1", A)  # told before its actor published anything
    assert board.state("uav1") is None


def test_an_action_told_to_a_robot_is_its_work_until_its_actor_shows_it() -> None:
    board = BidBoard()
    board.publish("uav1", BidState())
    board.started("uav1", A)
    assert board.state("uav1") == BidState(False, (A,))  # busy for the very next round
    shown = BidState(False, (Work("a", 3, 0.5),))
    board.publish("uav1", shown)
    assert board.state("uav1") == shown  # the actor's own figures, not twice
    board.publish("uav1", BidState())  # ended on the actor
    assert board.state("uav1") == BidState()


def test_an_action_that_ends_before_its_actor_shows_it_frees_the_robot() -> None:
    board = BidBoard()
    board.publish("uav1", BidState(teleop=True))
    board.started("uav1", A)
    board.ended("a")
    assert board.state("uav1") == BidState(teleop=True)


def test_a_dead_incarnation_withdraws_only_its_own_state() -> None:
    board = BidBoard()
    old, new = BidState(), BidState(teleop=True)
    board.publish("uav1", old)
    board.withdraw("uav1", old)
    assert board.state("uav1") is None
    board.publish("uav1", new)  # the next incarnation set up before the old one's teardown
    board.withdraw("uav1", old)
    assert board.state("uav1") is new


def test_teleop_told_to_a_robot_counts_until_its_actor_publishes_it() -> None:
    board = BidBoard()
    board.publish("uav1", BidState())
    board.started("uav1", A)
    board.teleop("uav1", True)  # told before its actor handled it
    assert board.state("uav1") == BidState(True, (A,))
    assert board.states() == {"uav1": BidState(True, (A,))}
    board.publish("uav1", BidState(teleop=True, work=(A,)))
    board.publish("uav1", BidState(teleop=False))  # the operator's teleop off came later
    assert board.state("uav1") == BidState(teleop=False)


def test_states_reads_every_robot_at_once_leaving_out_those_without_an_actor() -> None:
    board = BidBoard()
    board.publish("uav1", BidState())
    board.started("uav2", A)  # no state published: no bid
    board.publish("uav3", BidState(teleop=True))
    board.started("uav3", A)
    assert board.states() == {"uav1": BidState(), "uav3": BidState(True, (A,))}
