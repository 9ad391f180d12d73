"""Regression tests for the fixes the end-to-end tests led to (in-process; the process
versions are in test_kills.py): actions failed by the RCL lease are cancelled at the
RCL instead of running on for nobody; a restarted RCL hears the answers to the
statuses it restores."""

from __future__ import annotations

import textwrap
from pathlib import Path

import pytest

from mrss.actors.rcl.journal import ActionJournal, Requester
from mrss.actors.rcl.service import RclService
from mrss.actors.reasoner.core import Reasoner
from mrss.api import Action
from mrss.bus import BusEndpoints, ProxyThread, Publisher, Subscriber
from mrss.messages import (
    ActionControl,
    ActionRequest,
    ActionState,
    ActionStatus,
    Envelope,
    Percept,
)
from mrss.runtime.component import ComponentContext
from mrss.testing import wait_until

E2E_PROJECT = Path(__file__).resolve().parent.parent / "projects" / "e2e"

AGENT = """
+go(R, G)[source(percept)] <- !go(R, G).
+!go(R, G) <- patrol(R, G); +done(G).
-!go(R, G)[error_msg(M)] <- +failed(G, M).
"""


@pytest.fixture()
def project(tmp_path: Path) -> Path:
    (tmp_path / "agent.asl").write_text(textwrap.dedent(AGENT))
    return tmp_path


class Wire:
    def __init__(self) -> None:
        self.requests: list[ActionRequest] = []
        self.controls: list[ActionControl] = []


def _status(uuid: str, state: str, inc: int = 1) -> Envelope:
    body = ActionStatus(uuid=uuid, state=state, robot="ugv1")
    return Envelope(topic=body.topic(), id="m", ts=0.0, src="rcl", inc=inc, body=body)


def test_actions_failed_by_the_lease_are_cancelled_at_the_rcl_and_again_while_it_shows_them_open(
        project: Path) -> None:
    wire = Wire()
    reasoner = Reasoner(project / "agent.asl", name="reasoner",
                        send_request=wire.requests.append, send_control=wire.controls.append,
                        lease=0.3, tick=0.05)
    reasoner.start()
    try:
        reasoner.on_message(Envelope("percept", "p", 0.0, "events", 1,
                                     Percept(literal="go(ugv1, g1)")))
        (req,) = wait_until(lambda: wire.requests, message="request")
        # The RCL never speaks of it (a "running" sent now could come after a 0.3 s lease
        # that a stalled test thread let pass, and be cancelled once more, rightly).
        wait_until(lambda: reasoner.agent.believes("failed(g1, _)"), timeout=5,
                   message="the lease failed the intention")
        cancel = ActionControl(command="cancel", target=req.uuid, target_kind="action")
        assert wire.controls == [cancel]
        # the RCL comes back (or a restarted one resumes it): still open -> cancelled again
        reasoner.on_message(_status(req.uuid, "running", inc=2))
        assert wire.controls == [cancel, cancel]
        reasoner.on_message(_status(req.uuid, "cancelled", inc=2))
        reasoner.on_message(_status(req.uuid, "running", inc=2))  # forgotten once ended
        assert wire.controls == [cancel, cancel]
        assert not reasoner.agent.believes("done(g1)")
    finally:
        reasoner.stop()


def test_statuses_of_unknown_actions_send_nothing(project: Path) -> None:
    wire = Wire()
    reasoner = Reasoner(project / "agent.asl", name="reasoner",
                        send_request=wire.requests.append, send_control=wire.controls.append)
    try:
        reasoner.on_message(_status("someone-elses", "running"))
        assert wire.controls == []
    finally:
        reasoner.host.close()


def test_a_restarted_rcl_hears_the_answer_to_the_statuses_it_restores(tmp_path: Path) -> None:
    """RCL incarnation 2 re-announces a journaled action; a cancel sent the moment that
    status is seen must reach it (it used to subscribe only after announcing)."""
    journal_path = tmp_path / "rcl-journal.sqlite3"
    journal = ActionJournal(journal_path)
    journal.record(Action(uuid="left-open", name="patrol", args=["ugv1", "g", 400],
                          robot="ugv1", goal="g", state=ActionState.RUNNING),
                   requester=Requester("reasoner", 1))
    journal.close()
    endpoints = BusEndpoints.ipc(tmp_path)
    with ProxyThread(endpoints):
        pub = Publisher(endpoints, src="reasoner", inc=1)
        seen: list[ActionStatus] = []

        def answer(env: Envelope) -> None:  # what the reasoner does for an abandoned action
            assert isinstance(env.body, ActionStatus)
            seen.append(env.body)
            if env.body.state == "running":
                pub.publish(ActionControl(command="cancel", target=env.body.uuid))

        sub = Subscriber(endpoints, prefixes=["action.status"])
        sub.start(answer)
        service = RclService()
        ctx = ComponentContext(name="rcl", incarnation=2, project_dir=E2E_PROJECT,
                               run_dir=tmp_path, bus=endpoints.to_dict(),
                               options={"robots": {"ugv1": {"leg": 0.05}},
                                        "journal": str(journal_path)})
        try:
            assert sub.wait_connected(5) and pub.wait_connected(5)
            service.start(ctx)
            wait_until(lambda: [s for s in seen if s.state == "cancelled"], timeout=5,
                       message="the restored action cancelled")
            # transitions (progress statuses of the restored patrol are repeats)
            assert [s.state for s in seen if not s.repeat] == ["running", "cancelled"]
            assert "resumed after an RCL restart" in seen[0].reason
        finally:
            service.stop()
            ctx.publisher.close()
            sub.close()
            pub.close()
