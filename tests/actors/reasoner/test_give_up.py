"""Goals the agent gives up reach the operator as `GoalGaveUp`, with a reason of the
closed set and the last cause: the program's `give_up` after its retry budget, a failure
no `-!g` plan recovers, a goal with no applicable plan (the real interpreter and host)."""

from __future__ import annotations

import textwrap
from collections.abc import Iterator
from pathlib import Path

import pytest

from mrss.actors.reasoner.core import Reasoner
from mrss.messages import (
    ActionRequest,
    ActionStatus,
    FailureCause,
    GiveUpReason,
    GoalGaveUp,
    Percept,
    decode,
    encode,
)
from mrss.testing import wait_until
from tests.actors.reasoner.test_reasoner import env

AGENT = """
max_tries(2).
+order(G)[source(percept)] <- !reach(G, 1).
+!reach(G, N) <- move(uav1, G).
-!reach(G, N)[error(E)] : max_tries(M) & N < M <- !reach(G, N + 1).
-!reach(G, N)[error(E)] <- +gave_up(G); give_up(reach(G), budget_exhausted, E).
+probe(X)[source(percept)] <- !nobody_knows(X).
+fragile(X)[source(percept)] <- !break(X).
+!break(X) <- move(uav1, X).
+typo(X)[source(percept)] <- give_up(X, tired, none); +after_typo(X).
-typo(X)[source(percept)] <- true.
"""


@pytest.fixture()
def reasoner(tmp_path: Path) -> Iterator[tuple[Reasoner, list[ActionRequest], list[GoalGaveUp]]]:
    path = tmp_path / "agent.asl"
    path.write_text(textwrap.dedent(AGENT))
    requests: list[ActionRequest] = []
    alerts: list[GoalGaveUp] = []
    r = Reasoner(path, name="wildfire", send_request=requests.append,
                 send_control=lambda c: None, lease=30.0, tick=0.02, send_alert=alerts.append)
    r.start()
    try:
        yield r, requests, alerts
    finally:
        r.stop()


def fail(r: Reasoner, request: ActionRequest, cause: FailureCause) -> None:
    r.on_message(env(ActionStatus(uuid=request.uuid, state="failed", cause=cause)))


def test_a_goal_past_its_retry_budget_is_given_up_with_the_last_cause(
        reasoner: tuple[Reasoner, list[ActionRequest], list[GoalGaveUp]]) -> None:
    r, requests, alerts = reasoner
    r.on_message(env(Percept(literal="order(g1)"), src="events"))
    first = wait_until(lambda: requests and requests[0], message="the first try")
    fail(r, first, FailureCause.TRANSIENT)
    second = wait_until(lambda: len(requests) == 2 and requests[1], message="the retry")
    assert not alerts  # within its budget: no alert
    fail(r, second, FailureCause.LINK_DOWN)
    [alert] = wait_until(lambda: alerts, message="the alert")
    assert alert == GoalGaveUp(agent="wildfire", goal="reach(g1)",
                               reason=GiveUpReason.BUDGET_EXHAUSTED, cause="link_down",
                               message="given up by the program (budget_exhausted)")
    assert r.agent.believes("gave_up(g1)") and len(requests) == 2  # not sent to the RCL
    # as the wire carries it: the reason is the enum's value, read back as the member
    back = decode(*encode(alert, src="reasoner", inc=1)).body
    assert back == alert and back.reason is GiveUpReason.BUDGET_EXHAUSTED


def test_no_applicable_plan_and_an_unrecovered_failure_are_given_up(
        reasoner: tuple[Reasoner, list[ActionRequest], list[GoalGaveUp]]) -> None:
    r, requests, alerts = reasoner
    r.on_message(env(Percept(literal="probe(x1)"), src="events"))
    [no_plan] = wait_until(lambda: alerts, message="no plan")
    assert (no_plan.goal, no_plan.reason, no_plan.cause) == (
        "nobody_knows(x1)", GiveUpReason.NO_APPLICABLE_PLAN, "no_relevant")
    assert "no relevant plan for +!nobody_knows(x1)" in no_plan.message

    r.on_message(env(Percept(literal="fragile(x2)"), src="events"))
    action = wait_until(lambda: requests and requests[0], message="the action")
    fail(r, action, FailureCause.REJECTED)
    failed = wait_until(lambda: alerts[1:], message="the failure")[0]
    assert (failed.agent, failed.goal, failed.reason, failed.cause) == (
        "wildfire", "break(x2)", GiveUpReason.PLAN_FAILED, "rejected")
    assert "agent.asl:" in failed.message  # where the plan failed


def test_a_give_up_with_a_reason_outside_the_set_fails_and_publishes_nothing(
        reasoner: tuple[Reasoner, list[ActionRequest], list[GoalGaveUp]]) -> None:
    r, _, alerts = reasoner
    r.on_message(env(Percept(literal="typo(x3)"), src="events"))
    # the give_up fails its plan (error(rejected)); that failure, unhandled, is the alert
    [alert] = wait_until(lambda: alerts, message="the plan's failure")
    assert (alert.goal, alert.reason, alert.cause) == (
        "+typo(x3)", GiveUpReason.PLAN_FAILED, "rejected")
    assert not r.agent.believes("after_typo(x3)")
