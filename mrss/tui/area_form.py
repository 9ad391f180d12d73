"""AreaForm: the operator's "add an area" form (name, centre, radius, priority).

A modal screen of four inputs. Enter checks the field it is on
(`mrss.config.operator.AREA_FIELDS`) and moves on only when it is good; on the last
(or Ctrl+S anywhere) the whole area is checked (`area_payload`). A mistake is shown under
the form, the field at fault gets the cursor, and the form stays open with the text for
fixing; a good area dismisses the form with its payload. Esc closes it, sending nothing.
"""

from __future__ import annotations

from typing import Any, ClassVar

from rich.text import Text
from textual.app import ComposeResult
from textual.binding import Binding, BindingType
from textual.containers import Vertical
from textual.screen import ModalScreen
from textual.widgets import Input, Label, Static

from mrss.config.operator import AREA_FIELDS, PayloadError, area_payload

FIELDS = (("name", "name (a lowercase id, e.g. north)", ""),
          ("center", "centre LAT,LON (e.g. -35.3606,149.1652)", ""),
          ("radius", "radius in metres", "100"),
          ("priority", "priority (higher goes first)", "1"))


class AreaForm(ModalScreen[dict[str, Any] | None]):
    """The fields of a new area; the result is the area's payload, or None (Esc)."""

    DEFAULT_CSS = """
    AreaForm { align: center middle; }
    AreaForm > Vertical { width: 70; height: auto; border: thick $accent;
                          background: $surface; padding: 0 1; }
    AreaForm Input { height: 3; }
    AreaForm #form-error { height: auto; color: $error; text-style: bold; }
    """
    BINDINGS: ClassVar[list[BindingType]] = [
        Binding("escape", "cancel", "Close, send nothing"),
        Binding("ctrl+s", "submit", "Send the area"),
    ]

    def __init__(self, center: str = "") -> None:
        super().__init__()
        self.initial_center = center
        self.error = ""

    def compose(self) -> ComposeResult:
        with Vertical():
            yield Static(Text("Add an area (a goal for the agent)", style="bold"))
            for key, label, value in FIELDS:
                yield Label(label)
                yield Input(self.initial_center if key == "center" else value,
                            id=f"area-{key}")
            yield Static("", id="form-error")
            yield Static(Text("Enter: next field / send   Esc: close, send nothing",
                              style="dim"))

    def on_mount(self) -> None:
        self.query_one("#area-name", Input).focus()

    def on_input_submitted(self, event: Input.Submitted) -> None:
        event.stop()
        ids = [f"area-{key}" for key, _, _ in FIELDS]
        here = ids.index(event.input.id or ids[-1])
        key = FIELDS[here][0]
        try:
            AREA_FIELDS[key](event.input.value)
        except PayloadError as exc:
            self._show_error(exc)
            return
        self.error = ""
        self.query_one("#form-error", Static).update("")
        if here < len(ids) - 1:
            self.query_one(f"#{ids[here + 1]}", Input).focus()
        else:
            self.action_submit()

    def values(self) -> dict[str, str]:
        return {key: self.query_one(f"#area-{key}", Input).value for key, _, _ in FIELDS}

    def action_submit(self) -> None:
        try:
            payload = area_payload(**self.values())
        except PayloadError as exc:
            self._show_error(exc)
            return
        self.dismiss(payload)

    def _show_error(self, exc: PayloadError) -> None:
        """Say what is wrong under the form and put the cursor in the field at fault."""
        self.error = str(exc)
        self.query_one("#form-error", Static).update(Text(f"not sent: {exc}"))
        if exc.field is not None:
            self.query_one(f"#area-{exc.field}", Input).focus()

    def action_cancel(self) -> None:
        self.dismiss(None)
