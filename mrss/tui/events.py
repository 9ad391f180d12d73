"""The Textual messages the dashboard's widgets send up to the app.

Widgets never touch the bus: a key pressed on a panel becomes one of these, and the
app (which owns the `BusLink`) turns it into a bus message and says what it did.
"""

from __future__ import annotations

from textual.message import Message

from mrss.messages import Message as BusMessage


class BusActivity(Message):
    """The inbox has messages (posted from the subscriber thread)."""


class Note(Message):
    """A line for the operator's status bar: what was done, or what went wrong."""

    def __init__(self, text: str, *, error: bool = False) -> None:
        super().__init__()
        self.text = text
        self.error = error


class SendRequested(Message):
    """A widget wants `body` published on the bus; `what` describes it for the operator."""

    def __init__(self, body: BusMessage, what: str) -> None:
        super().__init__()
        self.body = body
        self.what = what
