"""How the dashboard steers: every bus message an operator asks for goes through here.

Widgets post `SendRequested` or `MissionRequested`; the app hands them to `Steering`,
which refuses them when read-only, asks the question first when there is one
(`ConfirmScreen`), publishes them (a project operator command through the
`MissionChannel`, on a worker thread), and says what happened. `X` (stop the system),
`H` (all robots hold), `U` (lift the stand-downs by area), the command menu and forms
(the project's declared commands, `mrss.tui.command_form`, and the stand-down by area,
`mrss.tui.stand_down`), the area form and the palette's "Send percept" are built here
too, as requests of the same kinds, so they pass the same checks.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from textual.app import App

from mrss.config.operator import GoalState, OperatorCommand, PayloadError, hold_payload
from mrss.config.operator_commands import CommandSpec, FieldType
from mrss.messages import Percept, StandDownState
from mrss.tui import operator, stand_down
from mrss.tui.area_form import AreaForm
from mrss.tui.buslink import BusLink
from mrss.tui.command_form import AREA_CHOICE, CommandForm, CommandMenu
from mrss.tui.confirm import ConfirmScreen
from mrss.tui.events import READONLY_NOTICE, MissionRequested, Say, SendRequested
from mrss.tui.mission import Answer, MissionChannel
from mrss.tui.models.actions import ActionsModel
from mrss.tui.models.goals import GoalsModel
from mrss.tui.models.robots import RobotsModel
from mrss.tui.models.supervision import SupervisionModel


class Steering:
    """The operator's side of the dashboard: sending, refusing, asking, reporting.

    `app` shows the questions and forms, posts the requests built here back to itself
    and runs the mission channel's worker; `say` reports. The models are read (the
    actions' history and the goals cancelled from here are written)."""

    def __init__(self, app: App[None], link: BusLink, say: Say, *, readonly: bool,
                 project: str, mission: MissionChannel | None,
                 supervision: SupervisionModel, robots: RobotsModel,
                 actions: ActionsModel, goals: GoalsModel) -> None:
        self.app = app
        self.link = link
        self.say = say
        self.readonly = readonly
        self.project = project
        self.mission = mission
        self.supervision = supervision
        self.robots = robots
        self.actions = actions
        self.goals = goals
        self.holding = False  # the last hold sent was "all robots hold"
        self.awaiting: dict[str, str] = {}  # goal -> the command sent for it, unanswered

    def _refused(self, what: str) -> bool:
        """Read-only: say that `what` is refused (and notify); True then."""
        if self.readonly:
            self.say(f"{what} refused: {READONLY_NOTICE}", error=True)
            self.app.notify(READONLY_NOTICE, severity="warning")
        return self.readonly

    def _ask(self, confirm: str, details: tuple[str, ...], what: str,
             send: Callable[[], None]) -> None:
        """`send` at once, or once the operator said yes to `confirm`."""
        if not confirm:
            send()
            return

        def answered(yes: bool | None) -> None:
            if yes:
                send()
            else:
                self.say(f"not sent (declined): {what}")

        self.app.push_screen(ConfirmScreen(confirm, details), answered)

    # -- bus messages (the debug keys, percepts, stop) -----------------------------------
    def send_requested(self, request: SendRequested) -> None:
        if self._refused(request.what):
            return
        self._ask(request.confirm, request.details, request.what,
                  lambda: self._send(request))

    def _send(self, request: SendRequested) -> None:
        try:
            self.link.publish(request.body)
        except Exception as exc:  # the dashboard stays up whatever the bus does
            self.say(f"not sent: {request.what}: {exc}", error=True)
            return
        if request.history is not None:
            uuid, note = request.history
            self.actions.note(uuid, time.time(), "operator (debug key)", note)
        self.say(f"sent {request.what}")

    # -- the project's operator commands: to the agent, as its events ------------------
    def mission_requested(self, request: MissionRequested) -> None:
        if self._refused(request.what):
            return
        command = request.command
        declared = (self.mission is not None and (
            self.mission.config.commands.get(command.name) == command
            if isinstance(command, CommandSpec) else self.mission.config.has(command)))
        if not declared:
            name = command.name if isinstance(command, CommandSpec) else command.value
            self.say(f"{request.what} not sent: the project declares no "
                     f"{name} command ([operator] in project.toml)", error=True)
            return
        self._ask(request.confirm, request.details, request.what,
                  lambda: self._send_mission(request))

    def _send_mission(self, request: MissionRequested) -> None:
        channel = self.mission
        assert channel is not None
        if request.command is OperatorCommand.CANCEL:
            self.goals.cancelled_here.add(str(request.payload.get("goal", "")))
        if request.command is OperatorCommand.HOLD:
            self.holding = bool(request.payload.get("on"))
        self.say(f"sending {request.what} to the agent ...")

        def work() -> None:
            answer = channel.send(request.command, request.payload)
            self.app.call_from_thread(self._mission_answer, request, answer)

        self.app.run_worker(work, thread=True, group="mission", exit_on_error=False)

    def _mission_answer(self, request: MissionRequested, answer: Answer) -> None:
        if answer.ok:
            self.say(f"sent {request.what} to the agent ({answer.text})")
            command = request.command
            goal = command.goal_of(request.payload) if isinstance(command, CommandSpec) else ""
            if goal:  # the agent's own answer comes in its beliefs: `follow_answers`
                self.awaiting[goal] = request.what
        else:
            if request.command is OperatorCommand.CANCEL:
                self.goals.cancelled_here.discard(str(request.payload.get("goal", "")))
            self.say(f"{request.what} not done: {answer.text}", error=True)

    def follow_answers(self) -> None:
        """Say the agent's answer to a command sent from here, once its beliefs show the
        goal the command named: queued, running, refused (with why), ..."""
        for goal, what in list(self.awaiting.items()):
            view = self.goals.goals.get(goal)
            if view is None:
                continue
            del self.awaiting[goal]
            why = self.goals.reason(view, self.actions)
            bad = view.state in (GoalState.FAILED, GoalState.REFUSED)
            self.say(f"agent: {goal} {view.state.value}" + (f": {why}" if why else "")
                     + f" ({what})", error=bad)

    def open_command_menu(self) -> None:
        """`n` on the mission panel: the project's declared commands (and the area form
        of the fixed vocabulary); a project that declares none gets the area form."""
        commands = self.mission.config.commands if self.mission is not None else {}
        if not commands:
            self.open_area_form()
            return
        if self.readonly:
            self.say(f"new command refused: {READONLY_NOTICE}", error=True)
            return
        choices = [(name, f"{name}: {spec.label}" if spec.label else name)
                   for name, spec in commands.items()]
        if self.mission is not None and self.mission.config.has(OperatorCommand.AREA):
            choices.append((AREA_CHOICE, "area: add an area (centre and radius)"))

        def chosen(name: str | None) -> None:
            if name is None:
                self.say("no command sent (menu closed)")
            elif name == AREA_CHOICE and name not in commands:
                self.open_area_form()
            else:
                self.open_command_form(commands[name])

        self.app.push_screen(CommandMenu(choices), chosen)

    def open_command_with(self, kind: FieldType, text: str) -> None:
        """A shape drawn on the map: the declared commands with a field of its kind (a
        menu when there are several), the form pre-filled with it."""
        commands = self.mission.config.commands if self.mission is not None else {}
        fitting = {name: spec for name, spec in commands.items()
                   if any(f.type is kind for f in spec.fields)}
        if kind in (FieldType.CIRCLE, FieldType.POLYGON):  # built in: to the RCL
            fitting[stand_down.NAME] = stand_down.spec(kind)
        if not fitting:
            self.say(f"no declared command takes a {kind.value} ([operator.commands]): "
                     f"{text[:60]}", error=True)
            return
        if self.readonly:
            self.say(f"new command refused: {READONLY_NOTICE}", error=True)
            return

        def open_form(name: str | None) -> None:
            if name is None:
                self.say("no command sent (menu closed)")
                return
            spec = fitting[name]
            target = next(f.name for f in spec.fields if f.type is kind)
            if name == stand_down.NAME:
                self.open_stand_down(spec, kind, text)
                return
            self.open_command_form(spec, {target: text})

        if len(fitting) == 1:
            open_form(next(iter(fitting)))
            return
        self.app.push_screen(CommandMenu([(n, f"{n}: {s.label}" if s.label else n)
                                          for n, s in fitting.items()]), open_form)

    def open_command_form(self, spec: CommandSpec,
                          prefill: dict[str, str] | None = None) -> None:
        """The form of one declared command; a good form goes to the agent."""
        if self.readonly:
            self.say(f"{spec.name} refused: {READONLY_NOTICE}", error=True)
            return

        def filled(payload: dict[str, object] | None) -> None:
            if payload is None:
                self.say(f"{spec.name} not sent (form closed)")
                return
            self.app.post_message(MissionRequested(spec, dict(payload), spec.summary(payload)))

        self.app.push_screen(CommandForm(spec, prefill), filled)

    def open_area_form(self) -> None:
        """The area form of the fixed vocabulary; its area goes to the agent."""
        if self.readonly:
            self.say(f"add an area refused: {READONLY_NOTICE}", error=True)
            return

        def filled(payload: dict[str, object] | None) -> None:
            if payload is None:
                self.say("area not sent (form closed)")
                return
            self.app.post_message(MissionRequested(
                OperatorCommand.AREA, dict(payload),
                f"area {payload['goal']} (priority {payload['priority']})"))

        self.app.push_screen(AreaForm(), filled)

    def open_stand_down(self, spec: CommandSpec, kind: FieldType, text: str) -> None:
        """The stand-down form for a drawn area; a good one is asked, then sent."""
        def filled(payload: dict[str, object] | None) -> None:
            if payload is None:
                self.say("stand-down not sent (form closed)")
                return
            self.app.post_message(stand_down.request(payload, kind, self.robots))

        self.app.push_screen(CommandForm(spec, {"area": text}), filled)

    def lift_stand_downs(self, active: dict[str, StandDownState]) -> None:
        """`U`: lift every active stand-down (one command, after a question)."""
        try:
            self.app.post_message(stand_down.lift(active))
        except operator.OperatorError as exc:
            self.say(str(exc), error=True)

    def hold_all(self) -> None:
        """`H`: all robots hold, or go on again (the agent suspends and resumes goals)."""
        on = not self.holding
        try:
            payload = hold_payload(on)
        except PayloadError as exc:
            self.say(str(exc), error=True)
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
        self.app.post_message(MissionRequested(OperatorCommand.HOLD, payload,
                                               "all robots hold" if on else "hold lifted",
                                               confirm=confirm, details=details))

    # -- what a request would affect, for its question -----------------------------------
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

    def stop_system(self) -> None:
        """`X`: stop the whole system through its root supervisor (asks first)."""
        if self._refused("stop"):
            return
        root = self.supervision.root or self.project
        try:
            request = operator.stop_request(root)
        except operator.OperatorError as exc:
            self.say(f"stop not sent: {exc}", error=True)
            return
        self.app.post_message(SendRequested(
            request, f"stop {root}", confirm=f"Stop the whole system {root}?",
            details=self.stop_details()))

    def send_percept(self, percept: Percept) -> None:
        """Send a percept as the percept line would (the palette's "Send percept")."""
        verb = "remove" if percept.op == "remove" else "add"
        self.app.post_message(SendRequested(percept, f"percept {verb} {percept.literal}"))
