"""The operator's answers to the agent's questions (`O`): sent until the reasoner replies.

An answer (`QuestionAnswer`, with who gives it: `operator_name()`) goes out on
`question.answer` and again every `RESEND` seconds until the reasoner's `AnswerReply`
with its request id comes, for at most `GIVE_UP` seconds (a reasoner restarting in
between gets a repeat; it answers a repeat of an answer it took as it did the first).
The reply is said on the status line: taken, or why not (already answered or timed
out, not a choice): then nothing changed.
"""

from __future__ import annotations

import getpass
import os
import time
from collections.abc import Callable
from contextlib import suppress

from textual.app import App

from mrss.messages import AnswerReply, AnswerVerdict, QuestionAnswer, new_id
from mrss.tui.buslink import BusLink
from mrss.tui.events import READONLY_NOTICE
from mrss.tui.models.questions import QuestionsModel
from mrss.tui.widgets.question_screen import QuestionScreen

RESEND = 1.0  # seconds between repeats of an answer not replied to
GIVE_UP = 30.0  # seconds after which an answer without a reply is reported lost

Say = Callable[..., None]


def operator_name() -> str:
    """Who answers from this dashboard: `MRSS_OPERATOR`, else the login name."""
    return os.environ.get("MRSS_OPERATOR") or getpass.getuser()


class AnswerDesk:
    """Opens the questions, sends the chosen answer and follows its reply."""

    def __init__(self, app: App[None], link: BusLink, say: Say, questions: QuestionsModel,
                 *, readonly: bool, clock: Callable[[], float] = time.monotonic) -> None:
        self.app = app
        self.link = link
        self.say = say
        self.questions = questions
        self.readonly = readonly
        self.clock = clock
        self.operator = operator_name()
        self.outstanding: dict[str, tuple[QuestionAnswer, float, float]] = {}

    def open(self) -> None:
        """`O`: the pending questions, to answer one."""
        if self.readonly:
            self.say(f"answer: {READONLY_NOTICE}", error=True)
            return
        pending = self.questions.pending()
        if not pending:
            self.say("no question of the agent waits for an answer")
            return

        def chosen(result: tuple[str, str] | None) -> None:
            if result is None:
                self.say("not answered (closed)")
            else:
                self.send(*result)
        self.app.push_screen(QuestionScreen(pending), chosen)

    def send(self, qid: str, choice: str) -> str:
        """Send `choice` as the answer to question `qid`; the request id."""
        msg = QuestionAnswer(id=qid, answer=choice, by=self.operator, request=new_id())
        now = self.clock()
        self.outstanding[msg.request] = (msg, now, now)
        with suppress(Exception):  # not connected: the repeats will do
            self.link.publish(msg)
        self.say(f"answer {choice!r} to question {qid} sent as {self.operator}; "
                 f"waiting for the reasoner")
        return msg.request

    def resend(self) -> None:
        """Once a second: repeat the answers not replied to; give up on old ones."""
        now = self.clock()
        for request, (msg, first, last) in list(self.outstanding.items()):
            if now - first > GIVE_UP:
                del self.outstanding[request]
                self.say(f"no reply from the reasoner to answer {msg.answer!r} for question "
                         f"{msg.id} within {GIVE_UP:.0f} s: it may not have arrived (O to "
                         f"answer again)", error=True)
            elif now - last >= RESEND:
                self.outstanding[request] = (msg, first, now)
                with suppress(Exception):
                    self.link.publish(msg)

    def on_reply(self, reply: AnswerReply) -> None:
        """The reasoner's word on one of this dashboard's answers (others' are ignored)."""
        if self.outstanding.pop(reply.request, None) is None:
            return
        if reply.verdict is AnswerVerdict.ACCEPTED:
            self.say(f"answer taken: {reply.message}")
        else:
            self.say(f"answer refused ({reply.verdict.value}): {reply.message}", error=True)
