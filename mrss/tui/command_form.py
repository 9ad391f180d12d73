"""CommandForm: the form of one of the project's declared operator commands.

Built from its declaration (`mrss.config.operator_commands.CommandSpec`): one input per
field, labelled with what to type (`LAT,LON; LAT,LON; ...`, the range, the units) and
filled with its default. Enter checks the field it is on and moves on only when it is
good; on the last (or Ctrl+S anywhere) every field is checked (`values_from_text`). A
mistake (out of range, a self-intersecting polygon, too many vertices, ...) is shown
under the form, the field at fault gets the cursor, and nothing is sent; a good form
dismisses with its payload. Esc closes it, sending nothing.
"""

from __future__ import annotations

from typing import Any, ClassVar

from rich.text import Text
from textual.app import ComposeResult
from textual.binding import Binding, BindingType
from textual.containers import VerticalScroll
from textual.screen import ModalScreen
from textual.widgets import Input, Label, OptionList, Static

from mrss.config.operator_commands import CommandError, CommandSpec


class CommandForm(ModalScreen[dict[str, Any] | None]):
    """The fields of `spec`; the result is the command's payload, or None (Esc)."""

    DEFAULT_CSS = """
    CommandForm { align: center middle; }
    CommandForm > VerticalScroll { width: 76; max-width: 100%; height: auto;
                                   max-height: 100%; border: thick $accent;
                                   background: $surface; padding: 0 1; }
    CommandForm Input { height: 3; }
    CommandForm #form-error { height: auto; color: $error; text-style: bold; }
    """
    BINDINGS: ClassVar[list[BindingType]] = [
        Binding("escape", "cancel", "Close, send nothing"),
        Binding("ctrl+s", "submit", "Send"),
    ]

    def __init__(self, spec: CommandSpec, prefill: dict[str, str] | None = None) -> None:
        """`prefill`: field name -> text in place of its default (a shape drawn on the map)."""
        super().__init__()
        self.spec = spec
        self.prefill = dict(prefill or {})
        self.error = ""

    def compose(self) -> ComposeResult:
        spec = self.spec
        with VerticalScroll():
            title = spec.label or spec.name
            yield Static(Text.assemble((title, "bold"), (f"  -> {spec.functor}/{spec.arity}",
                                                         "dim")))
            for field in spec.fields:
                yield Label(f"{field.label or field.name}: {field.hint()}")
                yield Input(self.prefill.get(field.name, field.default_text()),
                            id=f"cmd-{field.name}")
            yield Static("", id="form-error")
            yield Static(Text("Enter: next field / send   Esc: close, send nothing",
                              style="dim"))

    def on_mount(self) -> None:
        if self.spec.fields:
            self.query_one(f"#cmd-{self.spec.fields[0].name}", Input).focus()

    def on_input_submitted(self, event: Input.Submitted) -> None:
        event.stop()
        names = [f.name for f in self.spec.fields]
        here = names.index((event.input.id or "")[len("cmd-"):])
        try:
            self.spec.fields[here].from_text(event.input.value)
        except CommandError as exc:
            self._show_error(exc)
            return
        self.error = ""
        self.query_one("#form-error", Static).update("")
        if here < len(names) - 1:
            self.query_one(f"#cmd-{names[here + 1]}", Input).focus()
        else:
            self.action_submit()

    def values(self) -> dict[str, str]:
        return {f.name: self.query_one(f"#cmd-{f.name}", Input).value for f in self.spec.fields}

    def action_submit(self) -> None:
        try:
            payload = self.spec.values_from_text(self.values())
        except CommandError as exc:
            self._show_error(exc)
            return
        self.dismiss(payload)

    def _show_error(self, exc: CommandError) -> None:
        self.error = str(exc)
        self.query_one("#form-error", Static).update(Text(f"not sent: {exc}"))
        if exc.field is not None:
            self.query_one(f"#cmd-{exc.field}", Input).focus()

    def action_cancel(self) -> None:
        self.dismiss(None)


AREA_CHOICE = "area"  # the fixed vocabulary's area form, when the project declares it


class CommandMenu(ModalScreen[str | None]):
    """Which command to fill in: the project's declared ones (and `area` if it has it)."""

    DEFAULT_CSS = """
    CommandMenu { align: center middle; }
    CommandMenu > VerticalScroll { width: 60; max-width: 100%; height: auto;
                                   max-height: 100%; border: thick $accent;
                                   background: $surface; padding: 0 1; }
    CommandMenu OptionList { height: auto; max-height: 14; }
    """
    BINDINGS: ClassVar[list[BindingType]] = [Binding("escape", "cancel", "Close")]

    def __init__(self, choices: list[tuple[str, str]]) -> None:
        super().__init__()
        self.choices = choices  # (name, what the operator reads)

    def compose(self) -> ComposeResult:
        from textual.widgets.option_list import Option

        with VerticalScroll():
            yield Static(Text("New command to the agent", style="bold"))
            yield OptionList(*[Option(text, id=name) for name, text in self.choices],
                             id="command-menu")
            yield Static(Text("Enter: open its form   Esc: close", style="dim"))

    def on_mount(self) -> None:
        self.query_one(OptionList).focus()

    def on_option_list_option_selected(self, event: OptionList.OptionSelected) -> None:
        event.stop()
        self.dismiss(event.option.id)

    def action_cancel(self) -> None:
        self.dismiss(None)
