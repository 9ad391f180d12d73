"""How the dashboard steers: every bus message an operator asks for goes through here.

Widgets post `SendRequested` (or `Note`); `Steering` refuses it when read-only, asks
the question first when there is one (`ConfirmScreen`), publishes it, and says what
happened on the status line and in the log. `X` (stop the system) and the palette's
"Send percept" are built here too. `MrssApp` is a `Steering`.
"""

from __future__ import annotations

from contextlib import suppress

from textual.app import App
from textual.css.query import NoMatches

from mrss.messages import Percept
from mrss.tui import operator
from mrss.tui.buslink import BusLink
from mrss.tui.confirm import ConfirmScreen
from mrss.tui.events import READONLY_NOTICE, Note, SendRequested
from mrss.tui.models.actions import ActionsModel
from mrss.tui.models.robots import RobotsModel
from mrss.tui.models.supervision import SupervisionModel
from mrss.tui.widgets.log_pane import LogPane
from mrss.tui.widgets.operator_bar import OperatorBar


class Steering(App[None]):
    """The operator's side of the app: sending, refusing, asking, reporting."""

    readonly: bool
    project: str
    link: BusLink
    supervision: SupervisionModel
    robots: RobotsModel
    actions: ActionsModel

    def on_send_requested(self, request: SendRequested) -> None:
        if self.readonly:
            self._say(f"{request.what} refused: {READONLY_NOTICE}", error=True)
            self.notify(READONLY_NOTICE, severity="warning")
            return
        if not request.confirm:
            self._send(request)
            return

        def answered(yes: bool | None) -> None:
            if yes:
                self._send(request)
            else:
                self._say(f"not sent (declined): {request.what}")

        self.push_screen(ConfirmScreen(request.confirm, request.details), answered)

    def _send(self, request: SendRequested) -> None:
        try:
            self.link.publish(request.body)
        except Exception as exc:  # the dashboard stays up whatever the bus does
            self._say(f"not sent: {request.what}: {exc}", error=True)
            return
        self._say(f"sent {request.what}")

    def on_note(self, note: Note) -> None:
        self._say(note.text, error=note.error)

    def _say(self, text: str, *, error: bool = False) -> None:
        with suppress(NoMatches):  # the panels are gone: the app is closing
            self.query_one(OperatorBar).set_status(text, error=error)
            self.query_one(LogPane).note(text, error=error)

    def open_actions_of(self, robot: str) -> list[str]:
        """The names of the actions the dashboard knows open on `robot`."""
        return [view.name or view.uuid[:8] for view in self.actions.newest_first()
                if view.robot == robot and view.state and not view.terminal]

    def stop_details(self) -> list[str]:
        """What stopping the system stops, for the confirmation."""
        root = self.supervision.root or self.project
        components = [n.name for n in self.supervision.nodes.values()
                      if n.parent == root and n.state not in ("stopped", "gave up")]
        running = [v for v in self.actions.newest_first() if v.state and not v.terminal]
        return [f"components: {', '.join(components) or 'none known'}",
                f"robots: {', '.join(self.robots.robots) or 'none known'}",
                f"open actions: {len(running)} (ended as the RCL stops)"]

    def action_stop_system(self) -> None:
        if self.readonly:
            self._say(f"stop refused: {READONLY_NOTICE}", error=True)
            self.notify(READONLY_NOTICE, severity="warning")
            return
        root = self.supervision.root or self.project
        try:
            request = operator.stop_request(root)
        except operator.OperatorError as exc:
            self._say(f"stop not sent: {exc}", error=True)
            return
        self.post_message(SendRequested(
            request, f"stop {root}", confirm=f"Stop the whole system {root}?",
            details=self.stop_details()))

    def send_percept(self, percept: Percept) -> None:
        """Send a percept as the percept line would (the palette's "Send percept")."""
        verb = "remove" if percept.op == "remove" else "add"
        self.post_message(SendRequested(percept, f"percept {verb} {percept.literal}"))
