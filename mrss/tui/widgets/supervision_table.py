"""SupervisionTable: the supervision tree, one row per component or actor, with fault keys.

k / h / x inject a kill / hang (SIGSTOP) / crash into the selected component through the
root supervisor (`ctl.fault`). A fault is dangerous, so the key must be pressed twice
within `CONFIRM_SECONDS`. Only the root's own children (processes) can be hit this way.
"""

from __future__ import annotations

import time
from typing import ClassVar

from textual.binding import Binding, BindingType

from mrss.tui import operator
from mrss.tui.events import READONLY_NOTICE, Note, SendRequested, readonly
from mrss.tui.models.supervision import SupervisionModel, SupNode
from mrss.tui.widgets.keyed_table import KeyedTable, Row, cell

CONFIRM_SECONDS = 3.0
STATE_STYLES = {
    "running": "green", "starting": "yellow", "waiting": "yellow", "stopping": "yellow",
    "stopped": "dim", "exited": "red", "hung": "bold red", "quarantined": "bold red",
    "escalated": "bold red", "gave up": "bold red",
}
FAULT_KEYS = {"kill": "k", "hang": "h", "crash": "x"}


def uptime_text(seconds: float | None) -> str:
    """`45s`, `3m05s`, `2h07m`; empty when not running."""
    if seconds is None:
        return ""
    s = int(seconds)
    if s < 60:
        return f"{s}s"
    if s < 3600:
        return f"{s // 60}m{s % 60:02d}s"
    return f"{s // 3600}h{s % 3600 // 60:02d}m"


class SupervisionTable(KeyedTable):
    """Components and actors with state, restarts, uptime (what an operator looks at
    first, so it shows in a narrow panel), pid, incarnation, the input they refused (bad
    robot data, percepts, events, MAVLink messages), last reason."""

    COLUMNS = (("name", "component"), ("state", "state"), ("restarts", "restarts"),
               ("uptime", "uptime"), ("pid", "pid"), ("inc", "inc"), ("refused", "refused"),
               ("reason", "last exit reason"))
    BINDINGS: ClassVar[list[BindingType]] = [
        Binding("k", "fault('kill')", "Kill"),
        Binding("h", "fault('hang')", "Hang"),
        Binding("x", "fault('crash')", "Crash"),
    ]

    def __init__(self, model: SupervisionModel, *, id: str | None = None) -> None:
        super().__init__(id=id)
        self.model = model
        self._armed: tuple[str, str, float] | None = None

    def refresh_rows(self, now: float) -> None:
        self.show([self._row(node, now) for node in self.model.rows()])

    def _row(self, node: SupNode, now: float) -> Row:
        indent = "  " * node.depth
        return node.path, (
            cell(f"{indent}{node.name}", "bold" if node.kind == "supervisor" else ""),
            cell(node.state, STATE_STYLES.get(node.state, "")), cell(node.restarts),
            cell(uptime_text(node.uptime(now))),
            cell(node.pid or ""), cell(node.incarnation or ""),
            cell(node.refused or "", "bold yellow" if node.refused else ""),
            cell(node.last_reason, "italic"))

    def action_fault(self, kind: str) -> None:
        if readonly(self):
            self.post_message(Note(READONLY_NOTICE, error=True))
            return
        path = self.selected_key
        if path is None:
            self.post_message(Note("no component selected", error=True))
            return
        name = path.rsplit("/", 1)[-1]
        if not self.model.is_component(path):
            self.post_message(Note(f"{name}: faults reach only the root supervisor's "
                                   "components (processes), not actors", error=True))
            return
        now = time.monotonic()
        if self._armed is not None and self._armed[:2] == (path, kind) \
                and now < self._armed[2]:
            self._armed = None
            self.post_message(SendRequested(operator.fault(name, kind), f"{kind} {name}"))
            return
        self._armed = (path, kind, now + CONFIRM_SECONDS)
        self.post_message(Note(f"press {FAULT_KEYS[kind]} again within "
                               f"{CONFIRM_SECONDS:g} s to {kind} {name}"))
