"""The reasoner: percepts in, latched actions out, statuses release the latches."""

from __future__ import annotations

import itertools
import textwrap
from collections.abc import Iterator
from pathlib import Path

import pytest

from mrss.actors.reasoner.core import Reasoner
from mrss.messages import (
    ActionControl,
    ActionRequest,
    ActionStatus,
    Envelope,
    Message,
    Percept,
    SupEvent,
)
from mrss.testing import wait_until

AGENT = """
isuav(uav1).
+area(G, P)[source(percept)] <- !cover(uav1, G, P).
+!cover(R, G, P) : isuav(R) <- cover(R, G)[priority(P)]; +covered(G).
-!cover(R, G, P)[error_msg(M)] <- +cover_failed(G, M).
+cancel(G)[source(percept)] <- .drop_intention(cover(_, G, _)).
+teleop(R)[source(percept)] <- rcl_goal_management(suspend, robot(R)).
+resume(G)[source(percept)] <- rcl_goal_management(resume, G).
+robot_unavailable(R)[source(percept)] <- +saw_unavailable(R).
"""


class Wire:
    """Collects what the reasoner sends, as the bus would carry it."""

    def __init__(self) -> None:
        self.requests: list[ActionRequest] = []
        self.controls: list[ActionControl] = []


_IDS = itertools.count()


def env(body: Message, src: str = "rcl", inc: int = 1, msg_id: str | None = None) -> Envelope:
    """An envelope as the bus delivers it: a unique id unless one is given."""
    return Envelope(topic=body.topic(), id=msg_id or f"m{next(_IDS)}", ts=0.0, src=src,
                    inc=inc, body=body)


@pytest.fixture()
def wired(tmp_path: Path) -> Iterator[tuple[Reasoner, Wire]]:
    path = tmp_path / "agent.asl"
    path.write_text(textwrap.dedent(AGENT))
    wire = Wire()
    reasoner = Reasoner(path, name="reasoner", send_request=wire.requests.append,
                        send_control=wire.controls.append, lease=30.0, tick=0.05)
    reasoner.start()
    try:
        yield reasoner, wire
    finally:
        reasoner.stop()


def status(req: ActionRequest, state: str, reason: str = "") -> Envelope:
    return env(ActionStatus(uuid=req.uuid, state=state, reason=reason, robot=req.robot))


def test_percept_becomes_an_action_request_with_robot_goal_and_priority(
        wired: tuple[Reasoner, Wire]) -> None:
    reasoner, wire = wired
    reasoner.on_message(env(Percept(literal="area(g1, 3)"), src="events"))
    req = wait_until(lambda: wire.requests and wire.requests[0], message="action request")
    assert (req.name, req.args, req.robot, req.goal, req.priority) == (
        "cover", ["uav1", "g1"], "uav1", "g1", 3)
    assert req.literal == "cover(uav1,g1)"
    assert len(req.uuid) == 32


def test_terminal_success_releases_the_latch_and_the_plan_continues(
        wired: tuple[Reasoner, Wire]) -> None:
    reasoner, wire = wired
    reasoner.on_message(env(Percept(literal="area(g1, 3)")))
    req = wait_until(lambda: wire.requests and wire.requests[0])
    reasoner.on_message(status(req, "running"))
    assert not reasoner.agent.believes("covered(g1)")
    reasoner.on_message(status(req, "succeeded"))
    wait_until(lambda: reasoner.agent.believes("covered(g1)"), message="plan continued")
    assert reasoner.host.latches() == []


def test_progress_repeats_keep_the_latch_and_only_the_terminal_status_releases_it(
        wired: tuple[Reasoner, Wire]) -> None:
    """The RCL's throttled progress statuses (repeat=True, the current state again) are
    no transitions: the agent keeps waiting and sees the progress on its latch."""
    reasoner, wire = wired
    reasoner.on_message(env(Percept(literal="area(g1, 3)")))
    req = wait_until(lambda: wire.requests and wire.requests[0])
    reasoner.on_message(status(req, "running"))
    for leg in (1, 2, 3):
        reasoner.on_message(env(ActionStatus(uuid=req.uuid, state="running", robot=req.robot,
                                             progress={"leg": leg, "of": 4}, repeat=True,
                                             name=req.name, goal=req.goal)))
    [latch] = reasoner.host.latches()
    assert (latch.last_status, latch.progress) == ("running", {"leg": 3, "of": 4})
    assert not reasoner.agent.believes("covered(g1)") and wire.controls == []
    reasoner.on_message(status(req, "succeeded"))
    wait_until(lambda: reasoner.agent.believes("covered(g1)"), message="plan continued")
    assert reasoner.host.latches() == []


def test_failed_status_fails_the_plan_with_the_rcl_reason(wired: tuple[Reasoner, Wire]) -> None:
    reasoner, wire = wired
    reasoner.on_message(env(Percept(literal="area(g2, 1)")))
    req = wait_until(lambda: wire.requests and wire.requests[0])
    reasoner.on_message(status(req, "failed", "CoverArea raised RuntimeError: gps lost"))
    wait_until(lambda: reasoner.agent.believes("cover_failed(g2, _)"),
               message="failure handled by -!cover")
    (failed,) = [b for b in reasoner.agent.beliefs() if b.startswith("cover_failed")]
    assert "action failed: CoverArea raised RuntimeError: gps lost" in failed
    assert "agent.asl:4" in failed


def test_dropping_the_intention_cancels_its_action_at_the_rcl(
        wired: tuple[Reasoner, Wire]) -> None:
    reasoner, wire = wired
    reasoner.on_message(env(Percept(literal="area(g1, 3)")))
    req = wait_until(lambda: wire.requests and wire.requests[0])
    reasoner.on_message(env(Percept(literal="cancel(g1)")))
    control = wait_until(lambda: wire.controls and wire.controls[0], message="cancel")
    assert control == ActionControl(command="cancel", target=req.uuid, target_kind="action")
    # a late terminal status of the cancelled action changes nothing
    reasoner.on_message(status(req, "cancelled"))
    assert not reasoner.agent.believes("covered(g1)")
    assert not reasoner.agent.believes("cover_failed(g1, _)")


def test_goal_management_sends_controls_for_robots_and_goals(
        wired: tuple[Reasoner, Wire]) -> None:
    reasoner, wire = wired
    reasoner.on_message(env(Percept(literal="teleop(ugv1)")))
    reasoner.on_message(env(Percept(literal="resume(g7)")))
    wait_until(lambda: len(wire.controls) == 2, message="two controls")
    assert wire.controls == [
        ActionControl(command="suspend", target="ugv1", target_kind="robot"),
        ActionControl(command="resume", target="g7", target_kind="goal"),
    ]


def test_quarantine_becomes_a_robot_unavailable_percept(wired: tuple[Reasoner, Wire]) -> None:
    reasoner, _ = wired
    reasoner.on_message(env(SupEvent(event="quarantine", child="uav1",
                                     detail={"robot": "uav1"}), src="rcl"))
    wait_until(lambda: reasoner.agent.believes("saw_unavailable(uav1)"))
    assert reasoner.agent.believes("robot_unavailable(uav1)")
    reasoner.on_message(env(SupEvent(event="release", child="uav1", detail={"robot": "uav1"})))
    wait_until(lambda: not reasoner.agent.believes("robot_unavailable(uav1)"))


def test_malformed_percept_is_dropped_and_the_agent_keeps_serving(
        wired: tuple[Reasoner, Wire]) -> None:
    reasoner, wire = wired
    reasoner.on_message(env(Percept(literal="area(g1,, 3")))
    reasoner.on_message(env(Percept(literal="area(g3, 2)")))
    req = wait_until(lambda: wire.requests and wire.requests[0])
    assert req.goal == "g3"


def test_a_silent_rcl_fails_waiting_actions_after_the_lease(tmp_path: Path) -> None:
    path = tmp_path / "agent.asl"
    path.write_text(textwrap.dedent(AGENT))
    wire = Wire()
    reasoner = Reasoner(path, name="reasoner", send_request=wire.requests.append,
                        send_control=wire.controls.append, lease=0.3, tick=0.05)
    reasoner.start()
    try:
        reasoner.on_message(env(Percept(literal="area(g1, 3)")))
        wait_until(lambda: wire.requests, message="request")
        wait_until(lambda: reasoner.agent.believes("cover_failed(g1, M)"), timeout=5,
                   message="lease expiry failed the action")
        assert reasoner.host.latches() == []
    finally:
        reasoner.stop()
