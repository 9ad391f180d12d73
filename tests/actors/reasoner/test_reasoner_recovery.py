"""The reasoner's mission state across faults: the percept ledger re-asserted by a new
incarnation, reconciliation and the per-action lease, adoption of a predecessor's
actions, and failure causes reaching the agent's plans as `error(Cause)`."""

from __future__ import annotations

import textwrap
from collections.abc import Iterator
from pathlib import Path

import pytest

from mrss.actors.reasoner.core import Reasoner
from mrss.actors.reasoner.percept_guard import checked_literal
from mrss.actors.reasoner.percept_ledger import PerceptLedger
from mrss.messages import (
    ActionControl,
    ActionInventory,
    ActionQuery,
    ActionRequest,
    ActionStatus,
    FailureCause,
    Percept,
)
from mrss.runtime.datalayer_client import DataLayerError, DataLayerUnavailable
from mrss.testing import wait_until
from tests.actors.reasoner.test_reasoner import env

AGENT = """
+area(G, P)[source(percept)] <- !cover(uav1, G, P).
+!cover(R, G, P) <- cover(R, G)[priority(P)]; +covered(G);
                    -area(G, _)[source(percept)].
-!cover(R, G, P)[error(E)] <- +cover_failed(G, E).
"""


class Wire:
    """What the reasoner sends, as the bus would carry it."""

    def __init__(self) -> None:
        self.requests: list[ActionRequest] = []
        self.controls: list[ActionControl] = []
        self.queries: list[ActionQuery] = []


class Incarnations:
    """Start reasoners one after the other on the same ledger, as restarts would."""

    def __init__(self, tmp_path: Path) -> None:
        self.agent = tmp_path / "agent.asl"
        self.agent.write_text(textwrap.dedent(AGENT))
        self.ledger_path = tmp_path / "reasoner-percepts.sqlite3"
        self.running: list[tuple[Reasoner, PerceptLedger]] = []

    def start(self, inc: int, wire: Wire, **options: float) -> Reasoner:
        ledger = PerceptLedger(self.ledger_path, fresh=inc <= 1)
        reasoner = Reasoner(self.agent, name="reasoner", send_request=wire.requests.append,
                            send_control=wire.controls.append, tick=0.02,
                            send_query=wire.queries.append, ledger=ledger,
                            **options)  # type: ignore[arg-type]
        if inc > 1:
            reasoner.host.expect_inventory("reasoner", inc)
        reasoner.start()
        self.running.append((reasoner, ledger))
        return reasoner

    def kill(self, reasoner: Reasoner) -> None:
        """Process state goes; the ledger file stays (as after a SIGKILL)."""
        for pair in list(self.running):
            if pair[0] is reasoner:
                reasoner.stop()
                pair[1].close()
                self.running.remove(pair)

    def close(self) -> None:
        for reasoner, ledger in self.running:
            reasoner.stop()
            ledger.close()


@pytest.fixture()
def incarnations(tmp_path: Path) -> Iterator[Incarnations]:
    inc = Incarnations(tmp_path)
    try:
        yield inc
    finally:
        inc.close()


def test_a_percept_heard_on_both_paths_is_taken_once(incarnations: Incarnations) -> None:
    wire = Wire()
    reasoner = incarnations.start(1, wire)
    reasoner.on_message(env(Percept(literal="area(g1, 3)"), src="events", msg_id="same"))
    reasoner.on_message(env(Percept(literal="area(g1, 3)", op="remove"), src="events",
                            msg_id="same"))  # the second copy (a repeat) is not applied
    wait_until(lambda: wire.requests, message="the action of the percept")
    assert reasoner.ledger is not None and reasoner.ledger.standing() == ["area(g1, 3)"]


def test_a_new_incarnation_re_derives_its_goal_and_adopts_the_running_action(
    incarnations: Incarnations,
) -> None:
    wire1 = Wire()
    first = incarnations.start(1, wire1)
    first.on_message(env(Percept(literal="area(g1, 3)"), src="events"))
    old = wait_until(lambda: wire1.requests and wire1.requests[0])
    incarnations.kill(first)  # dies while cover(uav1,g1) runs at the RCL

    wire2 = Wire()
    second = incarnations.start(2, wire2)
    query = wait_until(lambda: [q for q in wire2.queries if q.requester], message="inventory")
    assert query[0] == ActionQuery(requester="reasoner", inc=2)
    assert wire2.requests == []  # held until the inventory says what is left
    second.on_message(env(ActionInventory(requester="reasoner", inc=2, actions=[
        {"uuid": old.uuid, "literal": old.literal, "goal": "g1", "robot": "uav1",
         "state": "running"}])))
    adopted = wait_until(lambda: wire2.requests and wire2.requests[0])
    assert (adopted.uuid, adopted.literal) == (old.uuid, old.literal)
    assert second.host.adopted == 1

    second.on_message(env(ActionStatus(uuid=old.uuid, state="succeeded"), inc=1))
    wait_until(lambda: second.agent.believes("covered(g1)"))
    # the plan consumed its percept: a third incarnation has nothing to redo
    assert second.ledger is not None
    wait_until(lambda: second.ledger is not None and second.ledger.standing() == [])


def test_a_new_incarnation_adopts_the_try_still_open_not_an_older_one_that_ended(
    incarnations: Incarnations,
) -> None:
    """Chaos (15 faults, seed 1): the inventory listed a supply the dead incarnation had
    seen fail (and tried again) before the try still running. The re-derived intention
    adopted the failed one: a spurious failure, a retry used up, and the running try an
    orphan until the next request. Only the open one is adoptable; with none open, the
    last that ended."""
    wire1 = Wire()
    first = incarnations.start(1, wire1)
    first.on_message(env(Percept(literal="area(g1, 3)"), src="events"))
    first.on_message(env(Percept(literal="area(g2, 1)"), src="events"))
    wait_until(lambda: len(wire1.requests) == 2)
    running = next(r for r in wire1.requests if r.goal == "g1")
    incarnations.kill(first)

    wire2 = Wire()
    second = incarnations.start(2, wire2)
    wait_until(lambda: [q for q in wire2.queries if q.requester], message="inventory")
    g2 = "cover(uav1,g2)"
    second.on_message(env(ActionInventory(requester="reasoner", inc=2, actions=[
        {"uuid": "f" * 32, "literal": running.literal, "state": "failed"},
        {"uuid": running.uuid, "literal": running.literal, "state": "running"},
        {"uuid": "e" * 32, "literal": g2, "state": "failed"},
        {"uuid": "d" * 32, "literal": g2, "state": "succeeded"}])))
    wait_until(lambda: len(wire2.requests) == 2)
    adopted = {r.literal: r.uuid for r in wire2.requests}
    assert adopted == {running.literal: running.uuid, g2: "d" * 32}
    assert second.host.adopted == 2


def test_without_an_inventory_a_new_incarnation_goes_on_after_adopt_wait(
    incarnations: Incarnations,
) -> None:
    wire1 = Wire()
    first = incarnations.start(1, wire1)
    first.on_message(env(Percept(literal="area(g2, 1)"), src="events"))
    wait_until(lambda: wire1.requests)
    incarnations.kill(first)
    wire2 = Wire()
    incarnations.start(2, wire2, adopt_wait=0.3)
    fresh = wait_until(lambda: wire2.requests and wire2.requests[0])
    assert fresh.literal == "cover(uav1,g2)" and fresh.uuid != wire1.requests[0].uuid


def test_waiting_actions_are_reconciled_and_a_lost_status_is_recovered(
    incarnations: Incarnations,
) -> None:
    wire = Wire()
    reasoner = incarnations.start(1, wire, reconcile=0.05)
    reasoner.on_message(env(Percept(literal="area(g1, 3)"), src="events"))
    req = wait_until(lambda: wire.requests and wire.requests[0])
    # the terminal status was lost on the bus: the reconciliation asks again
    asked = wait_until(lambda: [q for q in wire.queries if req.uuid in q.uuids])
    assert asked[0].requester == ""
    reasoner.on_message(env(ActionStatus(uuid=req.uuid, state="succeeded"), inc=1))
    wait_until(lambda: reasoner.agent.believes("covered(g1)"))
    wire.queries.clear()
    wait_until(lambda: reasoner.host.latches() == [])
    assert not [q for q in wire.queries if req.uuid in q.uuids][1:]  # no more asking


def test_an_action_the_rcl_never_speaks_of_fails_transient_on_its_lease(
    incarnations: Incarnations,
) -> None:
    wire = Wire()
    reasoner = incarnations.start(1, wire, lease=0.3, reconcile=0.05)
    reasoner.on_message(env(Percept(literal="area(g1, 3)"), src="events"))
    req = wait_until(lambda: wire.requests and wire.requests[0])
    # The RCL is alive (heartbeats, on every look) but knows nothing of the action: the
    # action's own lease fails it, not the RCL's silence.
    wait_until(lambda: reasoner.host.heard_from_rcl(1)
               or reasoner.agent.believes("cover_failed(g1, transient)"))
    assert any(c.command == "cancel" and c.target == req.uuid for c in wire.controls)


@pytest.mark.parametrize(("state", "cause", "error"), [
    ("failed", FailureCause.LINK_DOWN.value, "link_down"),
    ("cancelled", "", "cancelled"),
    ("failed", "", "action_failed"),
])
def test_a_failure_reaches_the_plan_with_its_cause(
    incarnations: Incarnations, state: str, cause: str, error: str,
) -> None:
    wire = Wire()
    reasoner = incarnations.start(1, wire)
    reasoner.on_message(env(Percept(literal="area(g1, 3)"), src="events"))
    req = wait_until(lambda: wire.requests and wire.requests[0])
    reasoner.on_message(env(ActionStatus(uuid=req.uuid, state=state, cause=cause)))
    wait_until(lambda: reasoner.agent.believes(f"cover_failed(g1, {error})"))


def test_the_ledger_keeps_standing_percepts_and_forgets_consumed_ones(tmp_path: Path) -> None:
    path = tmp_path / "ledger.sqlite3"
    ledger = PerceptLedger(path, fresh=True)
    ledger.add("area(g1, 3)")
    ledger.add("hotspot(h1, -35.1, 149.2)[temp(400)]")
    ledger.add("area(g1,3)")  # the same percept: keeps its first place
    ledger.remove("hotspot(h1,-35.1,149.2)")
    ledger.add("battery_low(uav1)")
    ledger.close()
    again = PerceptLedger(path)
    assert again.standing() == ["area(g1,3)", "battery_low(uav1)"]
    again.close()
    assert PerceptLedger(path, fresh=True).standing() == []


def test_a_percept_given_to_the_ledger_already_read_is_keyed_as_its_text(
        tmp_path: Path) -> None:
    ledger = PerceptLedger(tmp_path / "ledger.sqlite3", fresh=True)
    text = "hotspot(h1, -35.1, 149.2)[temp(400)]"
    ledger.add(text, checked_literal(text))
    ledger.add("hotspot(h1,-35.1,149.2)")  # the same percept, from its text
    ledger.add("area(g1, 3)", checked_literal("area(g1, 3)"))
    assert ledger.standing() == ["hotspot(h1,-35.1,149.2)", "area(g1, 3)"]
    ledger.remove(checked_literal("area(g1,3)[seen(2)]"))
    assert ledger.standing() == ["hotspot(h1,-35.1,149.2)"]
    ledger.close()


def test_a_data_layer_that_does_not_answer_fails_the_query_as_transient(tmp_path: Path) -> None:
    path = tmp_path / "agent.asl"
    path.write_text(textwrap.dedent("""
        +where(R)[source(percept)] <- !locate(R).
        +!locate(R) <- query(position, [R], P); +at(R, P).
        -!locate(R)[error(E)] <- +locate_failed(R, E).
    """))
    answers: dict[str, Exception] = {
        "uav1": DataLayerUnavailable("position", "no reply to 'position' within 0.1s"),
        "uav2": DataLayerError("position", "KeyError: 'uav2'"),
    }

    def data_call(function: str, args: list[object], timeout: float) -> object:
        raise answers[str(args[0])]

    wire = Wire()
    reasoner = Reasoner(path, name="reasoner", send_request=wire.requests.append,
                        send_control=wire.controls.append, data_call=data_call, tick=0.02)
    reasoner.start()
    try:
        reasoner.on_message(env(Percept(literal="where(uav1)"), src="events"))
        reasoner.on_message(env(Percept(literal="where(uav2)"), src="events"))
        wait_until(lambda: reasoner.agent.believes("locate_failed(uav1, transient)"))
        wait_until(lambda: reasoner.agent.believes("locate_failed(uav2, action_failed)"))
    finally:
        reasoner.stop()


def test_a_percept_sent_again_under_its_id_to_a_new_incarnation_is_not_acted_on_again(
    incarnations: Incarnations,
) -> None:
    """The events manager died after the reasoner had the goal but before the broker
    heard so: the broker's redelivery repeats the percept's id, and the ledger, which
    remembers the ids it took, takes it once, across a restart of the reasoner too."""
    wire1 = Wire()
    first = incarnations.start(1, wire1)
    first.on_message(env(Percept(literal="area(g1, 3)"), src="events", msg_id="ev-k.0"))
    action = wait_until(lambda: wire1.requests and wire1.requests[0])
    first.on_message(env(ActionStatus(uuid=action.uuid, state="succeeded"), inc=1))
    wait_until(lambda: first.ledger is not None and first.ledger.standing() == [],
               message="the goal done, its percept consumed")
    first.on_message(env(Percept(literal="area(g1, 3)"), src="events", msg_id="ev-k.0"))
    incarnations.kill(first)

    wire2 = Wire()
    second = incarnations.start(2, wire2, adopt_wait=0.0)
    second.on_message(env(Percept(literal="area(g1, 3)"), src="events", msg_id="ev-k.0"))
    second.on_message(env(Percept(literal="area(g2, 1)"), src="events", msg_id="ev-n.0"))
    later = wait_until(lambda: wire2.requests and wire2.requests[0], message="a new goal")
    assert later.literal == "cover(uav1,g2)"
    assert [r.literal for r in wire1.requests + wire2.requests] == [
        "cover(uav1,g1)", "cover(uav1,g2)"]
    assert second.ledger is not None and second.ledger.standing() == ["area(g2, 1)"]
