"""ConfirmScreen: a modal question before anything that stops, cancels or takes over.

It names what will be affected ("components: bus, rcl, reasoner", "robots: ugv1,
ugv2", "open actions: 2"), and only `y` says yes: `n`, `Esc` and every other key (but
the app's Ctrl-Q) say no and leave everything as it was; no key reaches the panels
underneath while it shows. The answer is the screen's result (`True` for yes).
"""

from __future__ import annotations

from collections.abc import Sequence

from rich.text import Text
from textual import events
from textual.app import ComposeResult
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

    def on_key(self, event: events.Key) -> None:
        """Any other key is a no: a stray key never confirms, nor acts underneath."""
        event.stop()
        event.prevent_default()
        self.dismiss(event.key == "y")
