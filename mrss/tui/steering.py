"""How the dashboard steers: every bus message an operator asks for goes through here.

Widgets post `SendRequested` (or `Note`); `Steering` refuses it when read-only, asks
the question first when there is one (`ConfirmScreen`), publishes it, and says what
happened on the status line and in the log. `X` (stop the system) and the palette's
"Send percept" are built here too. `MrssApp` is a `Steering`.
"""

from __future__ import annotations

import time
from contextlib import suppress

from textual.css.query import NoMatches

from mrss.config.operator import OperatorCommand, PayloadError, hold_payload
from mrss.messages import Percept
from mrss.tui import operator
from mrss.tui.area_form import AreaForm
from mrss.tui.buslink import BusLink
from mrss.tui.confirm import ConfirmScreen
from mrss.tui.events import READONLY_NOTICE, MissionRequested, Note, SendRequested
from mrss.tui.layout import PanelLayout
from mrss.tui.mission import Answer, MissionChannel
from mrss.tui.models.actions import ActionsModel
from mrss.tui.models.goals import GoalsModel
from mrss.tui.models.robots import RobotsModel
from mrss.tui.models.supervision import SupervisionModel
from mrss.tui.widgets.log_pane import LogPane
from mrss.tui.widgets.operator_bar import OperatorBar


class Steering(PanelLayout):
    """The operator's side of the app: sending, refusing, asking, reporting."""

    readonly: bool
    project: str
    link: BusLink
    supervision: SupervisionModel
    robots: RobotsModel
    actions: ActionsModel
    mission: MissionChannel | None
    goals: GoalsModel
    holding: bool

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
        if request.history is not None:
            uuid, note = request.history
            self.actions.note(uuid, time.time(), "operator (debug key)", note)
        self._say(f"sent {request.what}")

    # -- the project's operator commands: to the agent, as its events ------------------
    def on_mission_requested(self, request: MissionRequested) -> None:
        if self.readonly:
            self._say(f"{request.what} refused: {READONLY_NOTICE}", error=True)
            self.notify(READONLY_NOTICE, severity="warning")
            return
        if self.mission is None or not self.mission.config.has(request.command):
            self._say(f"{request.what} not sent: the project declares no "
                      f"{request.command.value} command ([operator] in project.toml)",
                      error=True)
            return
        if not request.confirm:
            self._send_mission(request)
            return

        def answered(yes: bool | None) -> None:
            if yes:
                self._send_mission(request)
            else:
                self._say(f"not sent (declined): {request.what}")

        self.push_screen(ConfirmScreen(request.confirm, request.details), answered)

    def _send_mission(self, request: MissionRequested) -> None:
        channel = self.mission
        assert channel is not None
        if request.command is OperatorCommand.CANCEL:
            self.goals.cancelled_here.add(str(request.payload.get("goal", "")))
        if request.command is OperatorCommand.HOLD:
            self.holding = bool(request.payload.get("on"))
        self._say(f"sending {request.what} to the agent ...")

        def work() -> None:
            answer = channel.send(request.command, request.payload)
            self.call_from_thread(self._mission_answer, request, answer)

        self.run_worker(work, thread=True, group="mission", exit_on_error=False)

    def _mission_answer(self, request: MissionRequested, answer: Answer) -> None:
        if answer.ok:
            self._say(f"sent {request.what} to the agent ({answer.text})")
        else:
            if request.command is OperatorCommand.CANCEL:
                self.goals.cancelled_here.discard(str(request.payload.get("goal", "")))
            self._say(f"{request.what} not done: {answer.text}", error=True)

    def open_area_form(self) -> None:
        """`n` on the mission panel: the form; its area goes to the agent."""
        if self.readonly:
            self._say(f"add an area refused: {READONLY_NOTICE}", error=True)
            return

        def filled(payload: dict[str, object] | None) -> None:
            if payload is None:
                self._say("area not sent (form closed)")
                return
            self.post_message(MissionRequested(
                OperatorCommand.AREA, dict(payload),
                f"area {payload['goal']} (priority {payload['priority']})"))

        self.push_screen(AreaForm(), filled)

    def action_hold_all(self) -> None:
        """`H`: all robots hold, or go on again (the agent suspends and resumes goals)."""
        on = not self.holding
        try:
            payload = hold_payload(on)
        except PayloadError as exc:
            self._say(str(exc), error=True)
            return
        robots = ", ".join(self.robots.robots) or "none known"
        if on:
            confirm, details = "All robots hold?", [
                f"robots: {robots}", "The agent suspends every running goal; new goals "
                "queue until the hold is lifted (H again)."]
        else:
            confirm, details = "Lift the hold: robots go on?", [
                f"robots: {robots}", "The agent resumes the best goal of each robot; they "
                "may start moving at once."]
        self.post_message(MissionRequested(OperatorCommand.HOLD, payload,
                                           "all robots hold" if on else "hold lifted",
                                           confirm=confirm, details=details))

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
