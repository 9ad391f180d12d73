"""The Textual messages the dashboard's widgets send up to the app.

Widgets never touch the bus: a key pressed on a panel becomes one of these, and the
app (which owns the `BusLink`) turns it into a bus message and says what it did. A
read-only dashboard refuses every `SendRequested`; one with a `confirm` question is
sent only once the operator said yes to it (`mrss.tui.confirm`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Protocol

from textual.message import Message

from mrss.config.operator import OperatorCommand
from mrss.config.operator_commands import CommandSpec
from mrss.messages import Message as BusMessage


class BusActivity(Message):
    """The inbox has messages (posted from the subscriber thread)."""


class Note(Message):
    """A line for the operator's status bar: what was done, or what went wrong."""

    def __init__(self, text: str, *, error: bool = False) -> None:
        super().__init__()
        self.text = text
        self.error = error


class Say(Protocol):
    """How the app's parts report to the operator: a line on the status bar and in the
    log (what a widget posts as a `Note`)."""

    def __call__(self, text: str, *, error: bool = False) -> None: ...


class SendRequested(Message):
    """A widget wants `body` published on the bus; `what` describes it for the operator."""

    def __init__(self, body: BusMessage, what: str, *, confirm: str = "",
                 details: Sequence[str] = (), history: tuple[str, str] | None = None) -> None:
        super().__init__()
        self.history = history  # (action uuid, note) for that action's history once sent
        self.body = body
        self.what = what
        self.confirm = confirm  # the question to ask first ("" : send at once)
        self.details = tuple(details)  # what it affects, for the question


READONLY_NOTICE = "read-only dashboard (--readonly): no controls"


def readonly(widget: object) -> bool:
    """Whether the widget's app is read-only (then every control is refused)."""
    return bool(getattr(getattr(widget, "app", None), "readonly", False))


class MissionRequested(Message):
    """A widget wants a project operator command sent to the agent (`mrss.tui.mission`):
    `command` (the fixed vocabulary's, or one the project declares) with its JSON
    `payload`; `what` describes it for the operator."""

    def __init__(self, command: OperatorCommand | CommandSpec, payload: dict[str, Any],
                 what: str, *,
                 confirm: str = "", details: Sequence[str] = ()) -> None:
        super().__init__()
        self.command = command
        self.payload = payload
        self.what = what
        self.confirm = confirm
        self.details = tuple(details)
