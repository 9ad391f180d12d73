"""The agent's questions to the operator through real processes (`mrss supervise`: the
bus proxy and the reasoner as OS processes, the root's incident record): a question
asked, the reasoner SIGKILLed while it is pending, the new incarnation asks it again
under the same id (a late observer sees it on `ctl.questions`), the operator's answer is
taken and the agent goes on with it; a second answer is refused and changes nothing; a
question nobody answers takes its default at its deadline; the incident record has the
questions, the answer and who gave it."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from mrss.auth.roles import Role
from mrss.auth.sessions import mint
from mrss.auth.store import Identity, OperatorStore, store_path
from mrss.bus import BusEndpoints, Publisher, Subscriber
from mrss.messages import (
    AnswerReply,
    AnswerVerdict,
    Command,
    Envelope,
    LogRecord,
    OperatorQuestion,
    Percept,
    QuestionAnswer,
    QuestionState,
    SupEvent,
)
from mrss.testing import stop_supervised, wait_until

pytestmark = pytest.mark.slow

PROJECT = "asking"
PROJECT_TOML = """\
[project]
name = "asking"

[supervisor]
strategy = "one_for_one"
intensity = 50
period = 30.0
heartbeat_interval = 0.5
heartbeat_misses = 600

[supervisor.backoff]
initial = 0.02
cap = 0.2
jitter = 0.0

[components.bus]
kind = "bus"

[components.reasoner]
kind = "reasoner"
adopt_wait = 0.2
"""

AGENT = """\
+enter(Z)[source(percept)]
   <- .ask_operator("Send the UGV into zone z1?", [go, hold], A);
      .print("entering ", Z, ": ", A); -enter(Z)[source(percept)].
+quick(Z)[source(percept)]
   <- .ask_operator("Sample now?", [yes, no], A, 1500, no);
      .print("sampling ", Z, ": ", A); -quick(Z)[source(percept)].
"""


class Run:
    """One `mrss supervise asking` and what the test saw on the bus."""

    def __init__(self, root: Path, users: bool = False) -> None:
        self.root = root
        folder = root / "projects" / PROJECT
        folder.mkdir(parents=True)
        (folder / "project.toml").write_text(PROJECT_TOML)
        (folder / "agent.asl").write_text(AGENT)
        self.credentials = _users(folder) if users else {}
        self.run_dir = root / "run"
        self.run_dir.mkdir()
        endpoints = BusEndpoints.ipc(self.run_dir)
        self._lock = threading.Lock()
        self.seen: list[Envelope] = []
        self.sub = Subscriber(endpoints, prefixes=["sup.tree", "log.", "question."])
        self.sub.start(self._keep)
        self.pub = Publisher(endpoints, src="tester")
        self._log = (root / "supervise.log").open("w")
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "mrss", "supervise", PROJECT, "--run-dir",
             str(self.run_dir)], env={**os.environ, "MRSS_PROJECTS": str(root / "projects")},
            stdout=self._log, stderr=subprocess.STDOUT, start_new_session=True)

    def _keep(self, env: Envelope) -> None:
        with self._lock:
            self.seen.append(env)

    def bodies(self, kind: type[Any]) -> list[Any]:
        with self._lock:
            return [e.body for e in self.seen if isinstance(e.body, kind)]

    def questions(self, state: QuestionState) -> list[OperatorQuestion]:
        return [q for q in self.bodies(OperatorQuestion) if q.state is state]

    def printed(self, text: str) -> int:
        return sum(1 for r in self.bodies(LogRecord) if r.component == "reasoner"
                   and r.message.endswith(text))

    def reasoner(self) -> dict[str, Any]:
        """The root's record of the reasoner once running (pid, incarnation)."""
        def running() -> dict[str, Any] | None:
            before = len(self.bodies(SupEvent))
            self.pub.publish(Command(command="tree"))
            try:
                tree = wait_until(lambda: [b for b in self.bodies(SupEvent)[before:]
                                           if b.event == "tree"], 2, interval=0.02)
            except AssertionError:
                return None
            kid = {k["id"]: k for k in tree[-1].detail["tree"]["children"]}.get("reasoner")
            return kid if kid and kid["state"] == "running" and kid["pid"] else None
        found: dict[str, Any] = wait_until(running, 60, interval=0.05,
                                           message=f"reasoner running\n{self.log_text()}")
        return found

    def ask(self, literal: str, question: str) -> OperatorQuestion:
        """Send the percept until the question it raises is heard of."""
        sent = [0]

        def heard() -> list[OperatorQuestion]:
            sent[0] += 1
            if sent[0] % 50 == 1:  # with users, as the operator otto (a percept needs it)
                self.pub.operator = self.credentials.get("otto", "")
                self.pub.publish(Percept(literal=literal))
            return [q for q in self.bodies(OperatorQuestion) if q.question == question]
        found: list[OperatorQuestion] = wait_until(heard, 60, interval=0.02,
                                                   message=f"question for {literal}")
        return found[0]

    def answer(self, qid: str, choice: str, by: str, request: str,
               credential: str = "") -> AnswerReply:
        """Send the answer until the reasoner replies (as the dashboard does), with an
        operator's credential if given."""
        msg = QuestionAnswer(id=qid, answer=choice, by=by, request=request)
        sent = [0]

        def replied() -> list[AnswerReply]:
            sent[0] += 1
            if sent[0] % 50 == 1:
                self.pub.operator = credential
                self.pub.publish(msg)
            return [r for r in self.bodies(AnswerReply) if r.request == request]
        found: list[AnswerReply] = wait_until(replied, 60, interval=0.02,
                                              message=f"reply to {request}")
        return found[0]

    def log_text(self) -> str:
        self._log.flush()
        return (self.root / "supervise.log").read_text(errors="replace")[-4000:]

    def close(self) -> None:
        try:
            stop_supervised(self.proc)
        finally:
            self.sub.close()
            self.pub.close()
            self._log.close()


def _users(folder: Path) -> dict[str, str]:
    """The project's operators: otto (operator, a personal token) and olga (observer, a
    session credential, as the dashboard makes after her login); their credentials."""
    otto = "mrss_" + "q" * 43
    store = OperatorStore.new(store_path(folder))
    store = store.with_user("otto", Role.OPERATOR, token=otto)
    store = store.with_user("olga", Role.OBSERVER, password="olga-secret-1")
    store.save()
    return {"otto": otto, "olga": mint(store, Identity("olga", Role.OBSERVER))}


@pytest.fixture(params=[False], ids=["no-users"])
def run(request: pytest.FixtureRequest) -> Iterator[Run]:
    root = Path(tempfile.mkdtemp(prefix="mrss-ask-"))
    system = Run(root, users=request.param)
    try:
        yield system
    finally:
        system.close()
        shutil.rmtree(root, ignore_errors=True)


def test_a_pending_question_survives_a_reasoner_kill_and_its_answer_is_recorded(
        run: Run) -> None:
    first = run.reasoner()
    asked = run.ask("enter(z1)", "Send the UGV into zone z1?")
    assert asked.choices == ["go", "hold"] and not asked.repeat

    os.kill(first["pid"], signal.SIGKILL)
    second = wait_until(lambda: (lambda r: r if r["pid"] != first["pid"] else None)(
        run.reasoner()), 60, message="the reasoner restarted")
    assert second["incarnation"] > first["incarnation"]
    again = wait_until(lambda: [q for q in run.bodies(OperatorQuestion) if q.repeat], 60,
                       message=f"the question asked again\n{run.log_text()}")[0]
    assert (again.id, again.state) == (asked.id, QuestionState.PENDING)
    before = len(run.bodies(OperatorQuestion))
    run.pub.publish(Command(command="questions"))  # a dashboard attaching late
    wait_until(lambda: any(q.id == asked.id for q in run.bodies(OperatorQuestion)[before:]),
               30, message="the pending question announced to a late dashboard")

    reply = run.answer(asked.id, "go", "alice", "req-1")
    assert reply.verdict is AnswerVerdict.ACCEPTED
    wait_until(lambda: run.printed("entering z1: go"), 60, message=run.log_text())
    second_try = run.answer(asked.id, "hold", "bob", "req-2")
    assert second_try.verdict is AnswerVerdict.ALREADY
    assert "already answered 'go' by alice" in second_try.message
    assert run.printed("entering z1: go") == 1 and run.printed("entering z1: hold") == 0

    quick = run.ask("quick(z2)", "Sample now?")
    timed_out = wait_until(lambda: run.questions(QuestionState.TIMED_OUT), 60,
                           message="the question timed out")[0]
    assert (timed_out.id, timed_out.answer, timed_out.by) == (quick.id, "no", "timeout")
    wait_until(lambda: run.printed("sampling z2: no"), 60, message=run.log_text())
    late = run.answer(quick.id, "yes", "alice", "req-3")
    assert late.verdict is AnswerVerdict.ALREADY and "timed out" in late.message

    record = run.run_dir / "incident.jsonl"

    def rows() -> list[dict[str, Any]]:
        if not record.is_file():
            return []
        return [json.loads(line) for line in record.read_text().splitlines()
                if '"kind":"question"' in line]
    found = wait_until(lambda: (lambda r: r if len(r) >= 4 else None)(rows()), 60,
                       message="the questions in the incident record")
    answered = [r for r in found if r["detail"]["state"] == "answered"]
    assert len(answered) == 1 and answered[0]["who"] == "alice"
    assert "answered 'go' by alice" in answered[0]["text"]
    assert [r["detail"]["state"] for r in found if r["subject"] == quick.id] == [
        "pending", "timed_out"]
    assert sum(1 for r in found if r["subject"] == asked.id and
               r["detail"]["state"] == "pending") == 1  # asked once: the adoption is a repeat


@pytest.mark.parametrize("run", [True], ids=["users"], indirect=True)
def test_with_users_an_observer_may_not_answer_and_an_answer_is_the_credentials_own(
        run: Run) -> None:
    run.reasoner()
    asked = run.ask("enter(z1)", "Send the UGV into zone z1?")
    stranger = run.answer(asked.id, "go", "otto", "req-1")  # no credential at all
    assert stranger.verdict is AnswerVerdict.REFUSED, stranger
    observer = run.answer(asked.id, "go", "olga", "req-2", run.credentials["olga"])
    assert observer.verdict is AnswerVerdict.REFUSED
    assert "the observer role may not send answer commands" in observer.message
    assert run.printed("entering z1: go") == 0 and not run.questions(QuestionState.ANSWERED)
    # an operator's answer is taken, as given by the identity its credential proves
    taken = run.answer(asked.id, "hold", "mallory", "req-3", run.credentials["otto"])
    assert taken.verdict is AnswerVerdict.ACCEPTED, taken
    answered = wait_until(lambda: run.questions(QuestionState.ANSWERED), 60,
                          message="the answer announced")[0]
    assert answered.by == "otto (operator)"
    wait_until(lambda: run.printed("entering z1: hold"), 60, message=run.log_text())
