"""The operator's extra views and tools, behind the app's keys and palette commands:

- `M`: the Messages screen (bus topics as a tree, latest message, history, rates);
- `L`: the log's lines, one to read in full;
- `!`: the alerts, acknowledged one by one;
- the palette's "Add a goal (area)", "Start recording" / "Stop recording".

Read-only refuses what changes anything (a goal, a recording written into the run dir).
"""

from __future__ import annotations

from collections.abc import Callable
from contextlib import suppress

from textual.app import App

from mrss.bus import BusEndpoints
from mrss.config.operator import OperatorCommand
from mrss.tui.events import READONLY_NOTICE, Say
from mrss.tui.mission import MissionChannel
from mrss.tui.models.alerts import AlertsModel
from mrss.tui.models.topics import TopicsModel
from mrss.tui.recorder import CONNECT_TIMEOUT, DashboardRecording, recording_path
from mrss.tui.widgets.alerts_list import AlertsScreen
from mrss.tui.widgets.alerts_strip import AlertsStrip
from mrss.tui.widgets.log_lines import LogLinesScreen
from mrss.tui.widgets.log_pane import LogPane
from mrss.tui.widgets.messages_view import MessagesScreen


class OperatorTools:
    """Opens the Messages, log-line and alerts screens on `app` (from its `LogPane` and
    `AlertsStrip` and the models); adds goals through `open_area_form` (the mission
    panel's `n`); records the bus at `endpoints`. `say` reports."""

    def __init__(self, app: App[None], say: Say, *, readonly: bool, endpoints: BusEndpoints,
                 topics: TopicsModel, alerts: AlertsModel, mission: MissionChannel | None,
                 open_area_form: Callable[[], None]) -> None:
        self.app = app
        self.say = say
        self.readonly = readonly
        self.endpoints = endpoints
        self.topics = topics
        self.alerts = alerts
        self.mission = mission
        self.open_area_form = open_area_form
        self.recording: DashboardRecording | None = None  # the one started last, if any

    # -- screens ---------------------------------------------------------------------------
    def messages(self) -> None:
        """`M`: the bus topics, their latest messages and rates."""
        if not isinstance(self.app.screen, MessagesScreen):
            self.app.push_screen(MessagesScreen(self.topics))

    def log_lines(self) -> None:
        """`L`: pick one log line, read it whole."""
        self.app.push_screen(LogLinesScreen(self.app.query_one(LogPane).shown_entries()))

    def alerts_list(self) -> None:
        """`!`: every alert; acknowledge one (Enter) or all (A)."""

        def changed(what: str) -> None:
            with suppress(Exception):  # the strip is gone: the app is closing
                self.app.query_one(AlertsStrip).show_alerts()
            self.say(what)

        self.app.push_screen(AlertsScreen(self.alerts, changed))

    # -- the palette's tools --------------------------------------------------------------
    def add_goal(self) -> None:
        """The palette's "Add a goal": the mission panel's area form (`n`)."""
        if self.readonly:
            self.open_area_form()  # which refuses, as `n` does
            return
        if self.mission is None or not self.mission.config.has(OperatorCommand.AREA):
            self.say("add a goal: the project declares no area command ([operator] area "
                     "in project.toml)", error=True)
            return
        self.open_area_form()

    def toggle_recording(self) -> None:
        """Start recording the bus into the run dir, or stop the recording running."""
        if self.recording is not None and self.recording.running:
            self.say(self.stop_recording())
            return
        if self.readonly:
            self.say(f"recording refused: {READONLY_NOTICE}", error=True)
            self.app.notify(READONLY_NOTICE, severity="warning")
            return
        endpoints = self.endpoints
        recording = self.recording = DashboardRecording(endpoints, recording_path(endpoints))
        recording.start()
        self.say(f"recording the bus to {recording.path} (palette: Stop recording)")
        for delay in (1.0, CONNECT_TIMEOUT + 1.0):  # a recording that could not start: say so
            self.app.set_timer(delay, lambda r=recording: self._recording_failed(r))

    def _recording_failed(self, recording: DashboardRecording) -> None:
        if recording is self.recording and recording.error and not recording.running:
            self.recording = None
            self.say(f"recording failed: {recording.error}", error=True)

    def stop_recording(self) -> str:
        """End the recording (if one runs); what happened."""
        recording, self.recording = self.recording, None
        if recording is None:
            return "no recording runs"
        return recording.stop()
