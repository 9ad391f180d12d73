"""ConfirmScreen: a modal question before anything that stops, cancels or takes over.

It names what will be affected ("stops: components bus, rcl, reasoner; robots ugv1,
ugv2 (2 actions running)"), and only `y` says yes: `n`, `Esc` (and every other key)
leave everything as it was. The answer is the screen's result (`True` for yes).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import ClassVar

from rich.text import Text
from textual.app import ComposeResult
from textual.binding import Binding, BindingType
from textual.containers import Vertical
from textual.screen import ModalScreen
from textual.widgets import Static


class ConfirmScreen(ModalScreen[bool]):
    """Ask `question`, listing `details`; `y` confirms, `n` / `Esc` decline."""

    DEFAULT_CSS = """
    ConfirmScreen { align: center middle; }
    ConfirmScreen > Vertical {
        width: 80; height: auto; max-height: 80%;
        border: thick $error; background: $surface; padding: 1 2;
    }
    ConfirmScreen #question { text-style: bold; }
    ConfirmScreen #details { margin: 1 0; }
    """
    BINDINGS: ClassVar[list[BindingType]] = [
        Binding("y", "answer(True)", "Yes"),
        Binding("n", "answer(False)", "No"),
        Binding("escape", "answer(False)", "No"),
    ]

    def __init__(self, question: str, details: Sequence[str] = (),
                 yes: str = "yes") -> None:
        super().__init__()
        self.question = question
        self.details = list(details)
        self.yes = yes

    def compose(self) -> ComposeResult:
        with Vertical():
            yield Static(Text(self.question), id="question")
            if self.details:
                yield Static(Text("\n".join(self.details)), id="details")
            yield Static(Text.assemble(("y", "bold"), f": {self.yes}    ",
                                       ("n", "bold"), " / ", ("Esc", "bold"),
                                       ": no, leave it running"), id="keys")

    def action_answer(self, yes: bool) -> None:
        self.dismiss(yes)
