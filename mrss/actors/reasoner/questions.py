"""The agent's questions to the operator (`.ask_operator`): asked, answered, timed out.

The rules, one place each:

- `ask`: the intention waits on the question (its handle). The same question (agent,
  text, choices) left by an earlier incarnation is adopted, oldest first: pending, the
  intention waits for it with its first deadline; settled and not yet consumed, the
  intention has its answer at once. Otherwise a new question is journaled, then
  published (`OperatorQuestion` on `question.<agent>`).
- `answer`: an operator's answer (`QuestionAnswer`) to a pending question settles it
  `answered`, with who gave it, journaled before the intention goes on; the reply
  (`AnswerReply`) says so. An answer to a question already settled is refused with what
  settled it (`already`), to no question (`unknown`), or not one of its choices
  (`invalid`, with "did you mean"): nothing else changes. A repeat of an answer taken
  (same request id) is answered `accepted` again.
- `tick`: a pending question past its deadline settles `timed_out` with its default
  answer, by "timeout", even one no live intention waits on (an adopter gets it).
- `withdraw`: the intention that asked was dropped: the question is `withdrawn`.
- `announce`: every pending question again (`repeat`), for a dashboard that attaches
  late (`ctl.questions`).

Every transition is `TRANSITIONS[(from, to)]`; another one is a bug and raises.
"""

from __future__ import annotations

import difflib
import logging
import threading
import time
import uuid as uuidlib
from collections.abc import Callable, Hashable
from typing import Any

from mrss.actors.reasoner.question_journal import Question, QuestionJournal
from mrss.agentspeak import Struct
from mrss.errors import MrssError
from mrss.messages import (
    AnswerReply,
    AnswerVerdict,
    OperatorQuestion,
    QuestionAnswer,
    QuestionState,
)

log = logging.getLogger("mrss.reasoner")

ASK = "ask_operator"
BY_TIMEOUT = "timeout"
P, A, T, W = (QuestionState.PENDING, QuestionState.ANSWERED, QuestionState.TIMED_OUT,
              QuestionState.WITHDRAWN)
TRANSITIONS: dict[tuple[QuestionState, QuestionState], str] = {
    (P, A): "an operator answered",
    (P, T): "nobody answered before the deadline: the default answer is taken",
    (P, W): "the intention that asked was dropped",
}

Complete = Callable[[Hashable, bool, "str | None", "Struct | None"], None]


def is_question(action: Struct) -> bool:
    return action.functor == ASK and len(action.args) == 5


def choice_text(term: Any) -> str:
    """A choice as the operator reads and types it: a string's text, an atom's name."""
    return term if isinstance(term, str) else str(getattr(term, "functor", term))


class OperatorQuestions:
    """The questions of one reasoner: journal, waiting intentions, answers, timeouts."""

    def __init__(self, journal: QuestionJournal, publish: Callable[[OperatorQuestion], object],
                 complete: Complete, *, clock: Callable[[], float] = time.time) -> None:
        self._journal = journal
        self._publish = publish
        self._complete = complete
        self._clock = clock
        self._lock = threading.Lock()
        self._questions: dict[str, Question] = {q.id: q for q in journal.all()}
        self._waiting: dict[str, tuple[Hashable, Struct]] = {}  # id -> (handle, action)
        self._by_handle: dict[Hashable, str] = {}
        left = sum(1 for q in self._questions.values() if not q.consumed)
        if left:
            log.info("%d question(s) to the operator left by an earlier incarnation", left)

    # ------------------------------------------------------------ the agent's side
    def ask(self, action: Struct, agent: str) -> Hashable:
        question, choices_term, _, timeout, default = action.args
        if not isinstance(question, str) or not isinstance(choices_term, tuple):
            raise MrssError(f"{ASK}: malformed question {action}")
        choices = [choice_text(c) for c in choices_term]
        now = self._clock()
        deadline = now + float(timeout) / 1000.0 \
            if isinstance(timeout, (int, float)) and timeout > 0 else 0.0
        handle = f"ask-{uuidlib.uuid4().hex}"
        with self._lock:
            q = self._adoptable(agent, question, choices)
            if q is None:
                q = Question(uuidlib.uuid4().hex[:12], agent, question, choices,
                             choice_text(default), deadline, now)
                self._journal.add(q)
                self._questions[q.id] = q
                log.info("%s asks the operator %s: %r %s", agent, q.id, question, choices)
                fresh = True
            else:
                log.info("%s asks again %s (left by an earlier incarnation, %s)", agent,
                         q.id, q.state.value)
                fresh = False
            self._waiting[q.id] = (handle, action)
            self._by_handle[handle] = q.id
            settled = q.state is not P
        if settled:  # answered (or timed out) while no intention waited: go on at once
            self._deliver(q)
        elif fresh:
            self._publish(self._message(q))
        else:
            self._publish(self._message(q, repeat=True))
        return handle

    def _adoptable(self, agent: str, question: str, choices: list[str]) -> Question | None:
        key = (agent, question, tuple(choices))
        for q in self._questions.values():  # oldest first
            if q.key == key and not q.consumed and q.id not in self._waiting and \
                    q.state is not W:
                return q
        return None

    def withdraw(self, handle: Hashable) -> bool:
        """The intention waiting on `handle` was dropped; False if it is not a question's."""
        with self._lock:
            qid = self._by_handle.pop(handle, None)
            if qid is None:
                return False
            self._waiting.pop(qid, None)
            q = self._questions[qid]
            if q.state is not P:
                return True
            self._settle(q, W, "", "", "")
        self._publish(self._message(q))
        return True

    # ------------------------------------------------------------ the operator's side
    def answer(self, msg: QuestionAnswer) -> AnswerReply:
        """Take an operator's answer, or say why not; the reply goes back to its sender."""
        with self._lock:
            q = self._questions.get(msg.id)
            if q is None:
                return AnswerReply(msg.request, msg.id, AnswerVerdict.UNKNOWN,
                                   f"no question {msg.id!r}: nothing changed")
            if q.state is not P:
                if q.state is A and q.request == msg.request:  # a repeat of the one taken
                    return AnswerReply(msg.request, q.id, AnswerVerdict.ACCEPTED,
                                       f"{q.id}: {q.answer} (by {q.by})")
                return AnswerReply(msg.request, q.id, AnswerVerdict.ALREADY,
                                   f"question {q.id} ({q.question!r}) was already "
                                   f"{self._how(q)}: your answer {msg.answer!r} changed "
                                   f"nothing")
            if msg.answer not in q.choices:
                close = difflib.get_close_matches(msg.answer, q.choices, n=1)
                hint = f"; did you mean {close[0]!r}?" if close else ""
                return AnswerReply(msg.request, q.id, AnswerVerdict.INVALID,
                                   f"{msg.answer!r} is not one of {', '.join(q.choices)}"
                                   f"{hint}: nothing changed")
            self._settle(q, A, msg.answer, msg.by, msg.request)
            live = q.id in self._waiting
        log.info("question %s answered %r by %s", q.id, q.answer, q.by)
        self._publish(self._message(q))
        if live:
            self._deliver(q)
        return AnswerReply(msg.request, q.id, AnswerVerdict.ACCEPTED,
                           f"{q.id}: {q.answer} (by {q.by})")

    def _how(self, q: Question) -> str:
        when = time.strftime("%H:%M:%S", time.localtime(q.answered_at))
        if q.state is A:
            return f"answered {q.answer!r} by {q.by} at {when}"
        if q.state is T:
            return f"timed out at {when} (default answer {q.answer!r} taken)"
        return f"withdrawn by the agent at {when}"

    def tick(self) -> None:
        """Settle the pending questions past their deadline with their default answer."""
        now = self._clock()
        due: list[Question] = []
        with self._lock:
            for q in self._questions.values():
                if q.state is P and q.deadline and now >= q.deadline:
                    self._settle(q, T, q.default, BY_TIMEOUT, "")
                    due.append(q)
        for q in due:
            log.warning("question %s timed out: default answer %r taken", q.id, q.answer)
            self._publish(self._message(q))
            if q.id in self._waiting:
                self._deliver(q)

    def announce(self) -> None:
        """Every pending question again, for a dashboard that attached late."""
        with self._lock:
            pending = [q for q in self._questions.values() if q.state is P]
        for q in pending:
            self._publish(self._message(q, repeat=True))

    # ------------------------------------------------------------ one place each
    def _settle(self, q: Question, to: QuestionState, answer: str, by: str,
                request: str) -> None:
        """Under the lock: the one transition of a question, journaled."""
        if (q.state, to) not in TRANSITIONS:
            raise MrssError(f"question {q.id}: no transition {q.state.value} -> {to.value}")
        q.state, q.answer, q.by, q.request = to, answer, by, request
        q.answered_at = self._clock()
        self._journal.settle(q)

    def _deliver(self, q: Question) -> None:
        """The waiting intention gets the answer; the journal says it was consumed."""
        with self._lock:
            waiting = self._waiting.pop(q.id, None)
            if waiting is None:
                return
            handle, action = waiting
            self._by_handle.pop(handle, None)
            q.consumed = True
            self._journal.settle(q)
        question, choices, _, timeout, default = action.args
        chosen = next((c for c in choices if choice_text(c) == q.answer), q.answer) \
            if isinstance(choices, tuple) else q.answer
        self._complete(handle, True, None,
                       Struct(ASK, (question, choices, chosen, timeout, default)))

    @staticmethod
    def _message(q: Question, *, repeat: bool = False) -> OperatorQuestion:
        return OperatorQuestion(id=q.id, agent=q.agent, question=q.question,
                                choices=list(q.choices), state=q.state, default=q.default,
                                deadline=q.deadline, asked_at=q.asked_at, answer=q.answer,
                                by=q.by, answered_at=q.answered_at, repeat=repeat)

    def get(self, qid: str) -> Question | None:
        with self._lock:
            return self._questions.get(qid)
