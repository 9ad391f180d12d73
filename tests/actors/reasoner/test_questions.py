"""The agent's questions to the operator (`.ask_operator`), in the reasoner without a bus:
the intention waits for the answer, a timeout takes the default, an answer to a settled
question changes nothing and says why, and a restarted reasoner adopts a pending question
(same id, same deadline) from its journal."""

from __future__ import annotations

import textwrap
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest

from mrss.actors.reasoner.core import Reasoner
from mrss.actors.reasoner.percept_ledger import PerceptLedger
from mrss.actors.reasoner.question_journal import QuestionJournal
from mrss.agentspeak import Agent
from mrss.messages import (
    AnswerReply,
    AnswerVerdict,
    Command,
    OperatorQuestion,
    Percept,
    QuestionAnswer,
    QuestionState,
)
from mrss.testing import wait_until
from tests.actors.reasoner.test_reasoner import env

AGENT = """
+enter(Z)[source(percept)]
   <- .ask_operator("Enter zone?", [go, hold], A);
      +chose(Z, A); -enter(Z)[source(percept)].
+quick(Z)[source(percept)]
   <- .ask_operator("Quick?", [yes, "no way"], A, 300, "no way");
      +chose(Z, A); -quick(Z)[source(percept)].
+bad(Z)[source(percept)] <- !bad(Z).
+!bad(Z) <- .ask_operator("Bad?", [a, b], A, 100, c).
-!bad(Z)[error(E)] <- +bad_failed(E).
"""


class Incarnations:
    """Reasoners started one after the other on the same ledger and question journal."""

    def __init__(self, tmp_path: Path) -> None:
        self.agent = tmp_path / "agent.asl"
        self.agent.write_text(textwrap.dedent(AGENT))
        self.tmp = tmp_path
        self.sent: list[OperatorQuestion | AnswerReply] = []
        self._lock = threading.Lock()
        self.running: list[tuple[Reasoner, PerceptLedger, QuestionJournal]] = []

    def start(self, inc: int) -> Reasoner:
        ledger = PerceptLedger(self.tmp / "percepts.sqlite3", fresh=inc <= 1)
        journal = QuestionJournal(self.tmp / "questions.sqlite3", fresh=inc <= 1)
        reasoner = Reasoner(self.agent, name="reasoner", send_request=lambda r: None,
                            send_control=lambda c: None, tick=0.02, ledger=ledger,
                            questions=journal, send_question=self._sent)
        reasoner.start()
        self.running.append((reasoner, ledger, journal))
        return reasoner

    def _sent(self, msg: OperatorQuestion | AnswerReply) -> None:
        with self._lock:
            self.sent.append(msg)

    def questions(self, state: QuestionState | None = None) -> list[OperatorQuestion]:
        with self._lock:
            return [m for m in self.sent if isinstance(m, OperatorQuestion)
                    and (state is None or m.state is state)]

    def replies(self) -> list[AnswerReply]:
        with self._lock:
            return [m for m in self.sent if isinstance(m, AnswerReply)]

    def answer(self, reasoner: Reasoner, qid: str, choice: str, by: str,
               request: str) -> AnswerReply:
        before = len(self.replies())
        reasoner.on_message(env(QuestionAnswer(id=qid, answer=choice, by=by, request=request),
                                src="tui"))
        return wait_until(lambda: self.replies()[before:], 30)[0]

    def kill(self, reasoner: Reasoner) -> None:
        for triple in list(self.running):
            if triple[0] is reasoner:
                reasoner.stop()
                triple[1].close()
                triple[2].close()
                self.running.remove(triple)

    def close(self) -> None:
        for reasoner, ledger, journal in self.running:
            reasoner.stop()
            ledger.close()
            journal.close()


@pytest.fixture()
def incs(tmp_path: Path) -> Iterator[Incarnations]:
    incarnations = Incarnations(tmp_path)
    try:
        yield incarnations
    finally:
        incarnations.close()


def _perceive(reasoner: Reasoner, literal: str) -> None:
    reasoner.on_message(env(Percept(literal=literal), src="events"))


def test_the_intention_waits_for_the_answer_and_a_second_answer_changes_nothing(
        incs: Incarnations) -> None:
    reasoner = incs.start(1)
    _perceive(reasoner, "enter(z1)")
    asked = wait_until(lambda: incs.questions(QuestionState.PENDING), 30)[0]
    assert (asked.question, asked.choices, asked.deadline) == ("Enter zone?", ["go", "hold"], 0)
    assert not reasoner.agent.believes("chose(z1, _)")  # it waits
    reply = incs.answer(reasoner, asked.id, "go", "alice", "r1")
    assert reply.verdict is AnswerVerdict.ACCEPTED
    wait_until(lambda: reasoner.agent.believes("chose(z1, go)"), 30)
    settled = incs.questions(QuestionState.ANSWERED)[0]
    assert (settled.answer, settled.by) == ("go", "alice")

    again = incs.answer(reasoner, asked.id, "hold", "bob", "r2")
    assert again.verdict is AnswerVerdict.ALREADY
    assert "already answered 'go' by alice" in again.message and "'hold'" in again.message
    repeat = incs.answer(reasoner, asked.id, "go", "alice", "r1")  # the first, sent again
    assert repeat.verdict is AnswerVerdict.ACCEPTED
    assert reasoner.agent.believes("chose(z1, go)")
    assert not reasoner.agent.believes("chose(z1, hold)")
    assert len(incs.questions(QuestionState.ANSWERED)) == 1
    assert reasoner.answers.total == 1  # the refusal was counted


def test_a_timeout_takes_the_default_and_a_late_answer_is_refused(incs: Incarnations) -> None:
    reasoner = incs.start(1)
    _perceive(reasoner, "quick(z2)")
    wait_until(lambda: reasoner.agent.believes('chose(z2, "no way")'), 30)
    settled = incs.questions(QuestionState.TIMED_OUT)[0]
    assert (settled.answer, settled.by) == ("no way", "timeout")
    late = incs.answer(reasoner, settled.id, "yes", "alice", "r3")
    assert late.verdict is AnswerVerdict.ALREADY and "timed out" in late.message
    assert not reasoner.agent.believes("chose(z2, yes)")


def test_an_answer_not_a_choice_or_to_no_question_is_refused_with_the_reason(
        incs: Incarnations) -> None:
    reasoner = incs.start(1)
    _perceive(reasoner, "enter(z3)")
    asked = wait_until(lambda: incs.questions(QuestionState.PENDING), 30)[0]
    wrong = incs.answer(reasoner, asked.id, "hodl", "alice", "r4")
    assert wrong.verdict is AnswerVerdict.INVALID
    assert "did you mean 'hold'?" in wrong.message
    assert incs.answer(reasoner, "nope", "go", "alice", "r5").verdict is AnswerVerdict.UNKNOWN
    assert incs.questions(QuestionState.PENDING) == [asked]  # still waiting, as it was
    assert incs.answer(reasoner, asked.id, "hold", "alice", "r6").verdict is \
        AnswerVerdict.ACCEPTED
    wait_until(lambda: reasoner.agent.believes("chose(z3, hold)"), 30)


def test_a_restarted_reasoner_adopts_its_pending_question(incs: Incarnations) -> None:
    first = incs.start(1)
    _perceive(first, "enter(z4)")
    asked = wait_until(lambda: incs.questions(QuestionState.PENDING), 30)[0]
    incs.kill(first)
    second = incs.start(2)  # the ledger asserts enter(z4) again: the agent asks again
    again = wait_until(lambda: [q for q in incs.questions() if q.repeat], 30)[0]
    assert again.id == asked.id and again.asked_at == asked.asked_at
    before = len(incs.questions())
    second.on_message(env(Command(command="questions"), src="tui"))  # a late dashboard
    assert [q.id for q in incs.questions()[before:]] == [asked.id]
    assert incs.answer(second, asked.id, "go", "carol", "r7").verdict is \
        AnswerVerdict.ACCEPTED
    wait_until(lambda: second.agent.believes("chose(z4, go)"), 30)
    assert len([q for q in incs.questions() if not q.repeat and q.state is
                QuestionState.PENDING]) == 1  # asked once, not twice


def test_bad_arguments_fail_the_intention_with_the_reason(incs: Incarnations) -> None:
    reasoner = incs.start(1)
    _perceive(reasoner, "bad(z5)")
    wait_until(lambda: reasoner.agent.believes("bad_failed(ia_failed)"), 30)
    assert incs.questions() == []


def test_without_a_host_that_knows_it_the_question_fails_the_intention() -> None:
    agent = Agent(textwrap.dedent("""
        !start.
        +!start <- .ask_operator("Go?", [go, hold], A); +went(A).
        -!start[error(E)] <- +failed(E).
        """), name="alone")
    agent.run_until_idle(max_cycles=100)
    assert agent.believes("failed(action_failed)")


def test_the_documented_example_parses() -> None:
    doc = (Path(__file__).resolve().parents[3] / "docs" / "mission.md").read_text()
    section = doc.split("## Questions to the operator", 1)[1]
    block = section.split("```agentspeak\n", 1)[1].split("```", 1)[0]
    assert ".ask_operator(" in block
    Agent(block, name="doc")  # loads: the internal action is known, the program parses
