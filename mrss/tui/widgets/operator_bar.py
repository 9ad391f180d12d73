"""OperatorBar: the percept input line and the status line under it.

Enter checks the line with the AgentSpeak parser: a ground literal becomes a `Percept`
(`-literal` removes one) and goes to the app to be sent; anything else is shown as an
error on the status line and nothing is sent (the text stays for fixing). A percept the
project's agent never names, or that no plan reacts to (`mrss.tui.vocabulary`), is not
sent at the first Enter: the status line says so and a second Enter on the same line
sends it anyway.
"""

from __future__ import annotations

from rich.text import Text
from textual.app import ComposeResult
from textual.containers import Vertical
from textual.widgets import Input, Static

from mrss.tui import operator
from mrss.tui.events import SendRequested
from mrss.tui.vocabulary import Vocabulary


class OperatorBar(Vertical):
    """Percept input plus a one-line status (what was sent, or what is wrong)."""

    DEFAULT_CSS = """
    OperatorBar { height: auto; }
    OperatorBar Input { height: 3; }
    OperatorBar #status { height: 1; padding: 0 1; }
    """

    def compose(self) -> ComposeResult:
        yield Input(placeholder="percept, e.g. fire(area1)   (-fire(area1) removes; Enter "
                    "sends)", id="percept")
        yield Static("", id="status")

    status_text = ""  # the status line as plain text
    status_error = False
    vocabulary = Vocabulary()  # the project's agent programs (empty: no warnings)
    _warned = ""  # the line last warned about: Enter on it again sends it

    def set_status(self, text: str, *, error: bool = False) -> None:
        self.status_text, self.status_error = text, error
        self.query_one("#status", Static).update(
            Text(text, style="bold red" if error else "green"))

    def on_input_submitted(self, event: Input.Submitted) -> None:
        event.stop()
        try:
            percept = operator.parse_percept(event.value)
        except operator.OperatorError as exc:
            self.set_status(f"percept not sent: {exc}", error=True)
            return
        line = f"{percept.op} {percept.literal}"
        warning = self.vocabulary.warning(percept.literal, remove=percept.op == "remove")
        if warning and self._warned != line:
            self._warned = line
            self.set_status(f"not sent yet: {warning}; Enter again sends it anyway",
                            error=True)
            return
        self._warned = ""
        event.input.value = ""
        verb = "remove" if percept.op == "remove" else "add"
        self.post_message(SendRequested(percept, f"percept {verb} {percept.literal}"))
