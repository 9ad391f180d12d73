"""The operator's extra views and tools: a base of `MrssApp`, for its keys and palette.

- `M`: the Messages screen (bus topics as a tree, latest message, history, rates);
- `L`: the log's lines, one to read in full;
- `!`: the alerts, acknowledged one by one;
- the palette's "Add a goal (area)", "Start recording" / "Stop recording".

Read-only refuses what changes anything (a goal, a recording written into the run dir).
"""

from __future__ import annotations

from contextlib import suppress

from textual.app import App

from mrss.config.operator import OperatorCommand
from mrss.tui.buslink import BusLink
from mrss.tui.events import READONLY_NOTICE
from mrss.tui.mission import MissionChannel
from mrss.tui.models.alerts import AlertsModel
from mrss.tui.models.topics import TopicsModel
from mrss.tui.recorder import CONNECT_TIMEOUT, DashboardRecording, recording_path
from mrss.tui.widgets.alerts_list import AlertsScreen
from mrss.tui.widgets.alerts_strip import AlertsStrip
from mrss.tui.widgets.log_lines import LogLinesScreen
from mrss.tui.widgets.log_pane import LogPane
from mrss.tui.widgets.messages_view import MessagesScreen


class OperatorTools(App[None]):
    """Opens the Messages, log-line and alerts screens; adds goals; records the bus."""

    readonly: bool
    link: BusLink
    topics: TopicsModel
    alerts: AlertsModel
    mission: MissionChannel | None
    recording: DashboardRecording | None = None

    def _say(self, text: str, *, error: bool = False) -> None:
        raise NotImplementedError

    def open_area_form(self) -> None:
        raise NotImplementedError

    # -- screens ---------------------------------------------------------------------------
    def action_messages(self) -> None:
        """`M`: the bus topics, their latest messages and rates."""
        if not isinstance(self.screen, MessagesScreen):
            self.push_screen(MessagesScreen(self.topics))

    def action_log_lines(self) -> None:
        """`L`: pick one log line, read it whole."""
        self.push_screen(LogLinesScreen(self.query_one(LogPane).shown_entries()))

    def action_alerts_list(self) -> None:
        """`!`: every alert; acknowledge one (Enter) or all (A)."""

        def changed(what: str) -> None:
            with suppress(Exception):  # the strip is gone: the app is closing
                self.query_one(AlertsStrip).show_alerts()
            self._say(what)

        self.push_screen(AlertsScreen(self.alerts, changed))

    # -- the palette's tools --------------------------------------------------------------
    def add_goal(self) -> None:
        """The palette's "Add a goal": the mission panel's area form (`n`)."""
        if self.readonly:
            self.open_area_form()  # which refuses, as `n` does
            return
        if self.mission is None or not self.mission.config.has(OperatorCommand.AREA):
            self._say("add a goal: the project declares no area command ([operator] area "
                      "in project.toml)", error=True)
            return
        self.open_area_form()

    def toggle_recording(self) -> None:
        """Start recording the bus into the run dir, or stop the recording running."""
        if self.recording is not None and self.recording.running:
            self._say(self.stop_recording())
            return
        if self.readonly:
            self._say(f"recording refused: {READONLY_NOTICE}", error=True)
            self.notify(READONLY_NOTICE, severity="warning")
            return
        endpoints = self.link.endpoints
        recording = self.recording = DashboardRecording(endpoints, recording_path(endpoints))
        recording.start()
        self._say(f"recording the bus to {recording.path} (palette: Stop recording)")
        for delay in (1.0, CONNECT_TIMEOUT + 1.0):  # a recording that could not start: say so
            self.set_timer(delay, lambda r=recording: self._recording_failed(r))

    def _recording_failed(self, recording: DashboardRecording) -> None:
        if recording is self.recording and recording.error and not recording.running:
            self.recording = None
            self._say(f"recording failed: {recording.error}", error=True)

    def stop_recording(self) -> str:
        """End the recording (if one runs); what happened."""
        recording, self.recording = self.recording, None
        if recording is None:
            return "no recording runs"
        return recording.stop()
