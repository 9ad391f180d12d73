"""Issue 29 item 1, end to end through real processes (bus proxy, RCL and reasoner under
`mrss supervise`): a message forged as the reasoner with a huge incarnation, from a raw
ZeroMQ socket, reaches the RCL; the RCL refuses it, counts it in its report, and still
runs the real reasoner's actions (before, it dropped every one of them)."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from mrss.messages import Command, Rejections, SupEvent, encode
from mrss.testing import wait_until
from tests.bus.bus_helpers import RawPublisher
from tests.e2e.system import System

pytestmark = pytest.mark.slow

HUGE = 10**9


@pytest.fixture()
def forger(system: System) -> Iterator[RawPublisher]:
    """Raw ZeroMQ publishing on the system's bus: anything may say anything."""
    sock = RawPublisher(system.endpoints).wait_joined(30)
    try:
        yield sock
    finally:
        sock.close()


def rcl_trees(system: System) -> int:
    """How many `sup.tree` snapshots the RCL has published (one per snapshot command)."""
    return sum(1 for e in system.envelopes(SupEvent)
               if e.src == "rcl" and isinstance(e.body, SupEvent) and e.body.event == "tree")


def test_a_message_forged_as_the_reasoner_with_a_huge_incarnation_silences_it_nowhere(
        system: System, forger: RawPublisher) -> None:
    # The RCL hears `ctl.snapshot` (the test's observer does not): forged as the reasoner,
    # then the same command of an unsupervised sender from the same socket, after it.
    forged = encode(Command(command="snapshot"), src="reasoner", inc=HUGE)
    marker = encode(Command(command="snapshot"), src="tester", inc=0)
    before = rcl_trees(system)

    def through_the_rcl() -> bool:
        forger.send_multipart(forged)
        forger.send_multipart(marker)
        return rcl_trees(system) > before

    wait_until(through_the_rcl, 30, interval=0.2, message="the forgery through the RCL")
    kind = "bus message from reasoner: an incarnation its supervisor did not start"

    def counted() -> bool:
        reports = [b for b in system.bodies(Rejections) if b.component == "rcl"]
        return bool(reports) and reports[-1].counts.get(kind, 0) > 0

    # the real reasoner (incarnation 1) still gets its actions run
    system.percept("area_goal_received(g1, 2)")
    cover = system.request("cover", "g1")
    assert cover.robot == "uav1"
    system.wait_state(cover.uuid, "succeeded", timeout=20)
    wait_until(counted, 20, message="the RCL's report counts the refusal")
