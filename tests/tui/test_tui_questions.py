"""The agent's questions on the dashboard (`.ask_operator`): a pending question raises an
alert, `O` shows it with its choices, the chosen answer goes to the reasoner (with who
gives it) until it replies, and the reply is said; a refused answer (already answered)
says why. A dashboard that attaches asks for the pending questions (`ctl.questions`)."""

from __future__ import annotations

import threading
from typing import Any

from mrss.bus import BusEndpoints, Subscriber
from mrss.messages import (
    AnswerReply,
    AnswerVerdict,
    Command,
    Envelope,
    OperatorQuestion,
    QuestionAnswer,
    QuestionState,
)
from mrss.tui.app import MrssApp
from mrss.tui.models.alerts import AlertKind
from mrss.tui.widgets.operator_bar import OperatorBar
from mrss.tui.widgets.question_screen import QuestionScreen
from tests.tui.tui_helpers import Peer, run, until

QUESTION = OperatorQuestion(id="q1", agent="reasoner", question="Enter zone z1?",
                            choices=["go", "hold", "abort"], state=QuestionState.PENDING,
                            default="hold", deadline=0.0, asked_at=1.0)


class Answers:
    """What the dashboard sends on `question.answer` and `ctl.questions`."""

    def __init__(self, endpoints: BusEndpoints) -> None:
        self._lock = threading.Lock()
        self.seen: list[Envelope] = []
        self.sub = Subscriber(endpoints, prefixes=["question.answer", "ctl.questions"])
        self.sub.start(self._keep)
        assert self.sub.wait_connected(10)

    def _keep(self, env: Envelope) -> None:
        with self._lock:
            self.seen.append(env)

    def answers(self) -> list[QuestionAnswer]:
        with self._lock:
            return [e.body for e in self.seen if isinstance(e.body, QuestionAnswer)]

    def asked_for_questions(self) -> bool:
        with self._lock:
            return any(isinstance(e.body, Command) and e.body.command == "questions"
                       for e in self.seen)


def _status(app: MrssApp) -> str:
    return str(app.query_one(OperatorBar).status_text)


def test_an_operator_answers_a_question_and_sees_the_reasoners_word(
        endpoints: BusEndpoints, peer: Peer, monkeypatch: Any) -> None:
    monkeypatch.setenv("MRSS_OPERATOR", "alice")
    answers = Answers(endpoints)

    async def body() -> None:
        app = MrssApp(endpoints, project="asking", mind_every=0, tree_every=0)
        async with app.run_test(size=(120, 35)) as pilot:
            await until(pilot, lambda: app.link.connected, 30, "connected")
            app.picture.ask_snapshot()
            await until(pilot, answers.asked_for_questions, 30, "ctl.questions asked")
            await until(pilot, lambda: (peer.publish(QUESTION, src="reasoner")
                                        or app.questions.pending()), 30, "question shown")
            alert = app.alerts.alerts[(AlertKind.QUESTION.value, "q1")]
            assert "Enter zone z1?" in alert.text and "O to answer" in alert.text
            assert alert.severe

            await pilot.press("O")
            screen = await until(pilot, lambda: isinstance(app.screen, QuestionScreen)
                                 and app.screen, 10, "question screen")
            assert "Enter zone z1?" in str(screen.query_one("#asked").render())
            await pilot.press("3", "escape")  # closing answers nothing
            await until(pilot, lambda: not isinstance(app.screen, QuestionScreen), 10)
            assert "not answered" in _status(app)
            assert answers.answers() == []

            await pilot.press("O")
            await until(pilot, lambda: isinstance(app.screen, QuestionScreen), 10)
            await pilot.press("down", "enter")  # the second choice: hold
            sent = await until(pilot, answers.answers, 30, "answer sent")
            assert (sent[0].id, sent[0].answer, sent[0].by) == ("q1", "hold", "alice")
            assert "waiting for the reasoner" in _status(app)
            peer.publish(AnswerReply(request=sent[0].request, id="q1",
                                     verdict=AnswerVerdict.ACCEPTED,
                                     message="q1: hold (by alice)"), src="reasoner")
            await until(pilot, lambda: "answer taken: q1: hold (by alice)" in _status(app),
                        30, "the reply said")
            assert app.answers.outstanding == {}

            settled = OperatorQuestion(**{**QUESTION.__dict__, "state":
                                          QuestionState.ANSWERED, "answer": "hold",
                                          "by": "alice"})
            peer.publish(settled, src="reasoner")
            await until(pilot, lambda: not app.questions.pending(), 30, "settled")
            assert app.alerts.alerts[(AlertKind.QUESTION.value, "q1")].resolved
            await pilot.press("O")
            assert "no question of the agent waits" in _status(app)

            # another dashboard's stale view: an answer to a settled question is refused
            request = app.answers.send("q1", "go")
            peer.publish(AnswerReply(request=request, id="q1", verdict=AnswerVerdict.ALREADY,
                                     message="question q1 ('Enter zone z1?') was already "
                                             "answered 'hold' by alice at 10:00:00: your "
                                             "answer 'go' changed nothing"), src="reasoner")
            await until(pilot, lambda: "answer refused (already)" in _status(app), 30)
            assert "changed nothing" in _status(app)
    run(body())
    answers.sub.close()


def test_a_read_only_dashboard_does_not_answer(endpoints: BusEndpoints, peer: Peer) -> None:
    async def body() -> None:
        app = MrssApp(endpoints, project="asking", mind_every=0, tree_every=0, readonly=True)
        async with app.run_test(size=(120, 35)) as pilot:
            await until(pilot, lambda: app.link.connected, 30, "connected")
            await until(pilot, lambda: (peer.publish(QUESTION, src="reasoner")
                                        or app.questions.pending()), 30, "question shown")
            await pilot.press("O")
            assert "read-only" in _status(app)
            assert not isinstance(app.screen, QuestionScreen)
    run(body())
