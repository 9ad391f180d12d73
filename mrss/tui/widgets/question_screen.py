"""QuestionScreen: the agent's pending questions, one at a time, and the operator's pick.

The oldest pending question shows first with its choices numbered; `1`..`9` (or the
arrows) select a choice, Enter answers with it, Tab shows the next question, Esc closes
without answering. The default answer (taken if nobody answers before the deadline) is
marked. The result is `(question id, choice)` or None.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import ClassVar

from rich.text import Text
from textual.app import ComposeResult
from textual.binding import Binding, BindingType
from textual.containers import Vertical
from textual.reactive import reactive
from textual.screen import ModalScreen
from textual.widgets import Static

from mrss.messages import OperatorQuestion


class QuestionScreen(ModalScreen[tuple[str, str] | None]):
    """Answer one of `questions` (the pending ones when it opened)."""

    DEFAULT_CSS = """
    QuestionScreen { align: center middle; }
    QuestionScreen > Vertical {
        width: 84; height: auto; max-height: 90%;
        border: thick $warning; background: $surface; padding: 1 2;
    }
    QuestionScreen #asked { text-style: bold; }
    QuestionScreen #choices { margin: 1 0; }
    """
    BINDINGS: ClassVar[list[BindingType]] = [
        Binding("escape", "close", "Close"),
        Binding("enter", "answer", "Answer"),
        Binding("tab", "next_question", "Next question"),
        Binding("up", "move(-1)", "Up", show=False),
        Binding("down", "move(1)", "Down", show=False),
        *(Binding(str(n), f"pick({n - 1})", str(n), show=False) for n in range(1, 10)),
    ]

    index: reactive[int] = reactive(0)
    choice: reactive[int] = reactive(0)

    def __init__(self, questions: Sequence[OperatorQuestion],
                 clock: Callable[[], float] = time.time) -> None:
        super().__init__()
        self.questions = list(questions)
        self.clock = clock

    def compose(self) -> ComposeResult:
        with Vertical():
            yield Static("", id="asked")
            yield Static("", id="choices")
            yield Static(Text.assemble(("1-9", "bold"), "/", ("↑↓", "bold"), " choose  ",
                                       ("Enter", "bold"), " answer  ", ("Tab", "bold"),
                                       " next question  ", ("Esc", "bold"), " close"),
                         id="keys")

    def on_mount(self) -> None:
        self._show()

    @property
    def current(self) -> OperatorQuestion:
        return self.questions[self.index]

    def _show(self) -> None:
        q = self.current
        count = f" ({self.index + 1} of {len(self.questions)})" if len(self.questions) > 1 \
            else ""
        left = ""
        if q.deadline:
            left = f"\nno answer within {max(0, q.deadline - self.clock()):.0f} s: " \
                   f"{q.default!r} is taken"
        self.query_one("#asked", Static).update(
            Text(f"{q.agent} asks{count}: {q.question}{left}"))
        lines = Text()
        for n, choice in enumerate(q.choices):
            mark = "▶ " if n == self.choice else "  "
            default = "  (default)" if q.deadline and choice == q.default else ""
            lines.append(f"{mark}{n + 1}  {choice}{default}\n",
                         style="reverse" if n == self.choice else "")
        self.query_one("#choices", Static).update(lines)

    def watch_index(self) -> None:
        if self.is_mounted:
            self.choice = 0
            self._show()

    def watch_choice(self) -> None:
        if self.is_mounted:
            self._show()

    def action_move(self, step: int) -> None:
        self.choice = (self.choice + step) % len(self.current.choices)

    def action_pick(self, n: int) -> None:
        if n < len(self.current.choices):
            self.choice = n

    def action_next_question(self) -> None:
        self.index = (self.index + 1) % len(self.questions)

    def action_answer(self) -> None:
        q = self.current
        self.dismiss((q.id, q.choices[self.choice]))

    def action_close(self) -> None:
        self.dismiss(None)
