"""The command palette's MRSS commands (Ctrl+P): follow a robot on the map, send a
percept typed into the palette, add a goal (the area form), refresh the whole picture,
acknowledge the alerts (all, or one in the alerts list), open the Messages view or the
log's lines, start or stop a recording of the bus into the run dir.

Each command calls a public method of `MrssApp`, the same the keys use, so the palette
goes through the same checks (read-only, questions) as the keys.
"""

from __future__ import annotations

from functools import partial
from typing import Any

from textual.command import DiscoveryHit, Hit, Hits, Provider

from mrss.tui import operator


class MrssCommands(Provider):
    """Commands made from what the dashboard knows now (robots on the map)."""

    def _commands(self, query: str) -> list[tuple[str, Any, str]]:
        app: Any = self.app
        commands: list[tuple[str, Any, str]] = [
            ("Refresh snapshot", app.action_refresh_all,
             "ask for tree, robots, open actions and mind now (F5)"),
            ("Acknowledge alerts", app.action_ack_alerts, "clear the alerts' highlight (A)"),
            ("Alerts: list, acknowledge one", app.action_alerts_list,
             "every alert; Enter acknowledges the one under the cursor (!)"),
            ("Map: fit everything", app.map_fit, "zoom the map to show everything (0)"),
            ("Messages: bus topics", app.action_messages,
             "topics as a tree, latest message as JSON, history, rates (M)"),
            ("Log: read one line in full", app.action_log_lines,
             "the log's lines with a cursor; the chosen one whole (L)"),
            ("Add a goal (area)", app.add_goal,
             "the mission panel's area form: the agent gets a new area (n)"),
        ]
        running = app.recording is not None and app.recording.running
        commands.append(("Stop recording" if running else "Start recording",
                         app.toggle_recording,
                         "stop writing the bus to the file" if running else
                         "write every bus message to <run dir>/recording-*.mrssrec "
                         "(mrss replay plays it)"))
        for robot in app.map_model.robots:
            commands.append((f"Map: follow {robot}", partial(app.map_follow, robot),
                             f"centre the map on {robot} and keep it there"))
        text = query.strip()
        literal = text.split(None, 1)[1] if text.lower().startswith("percept ") else text
        try:
            percept = operator.parse_percept(literal)
        except operator.OperatorError:
            pass
        else:
            sign = "-" if percept.op == "remove" else ""
            warning = app.vocabulary.warning(percept.literal, remove=percept.op == "remove")
            commands.append((f"Send percept {sign}{percept.literal}",
                             partial(app.send_percept, percept),
                             f"careful: {warning}" if warning else
                             "to the reasoner, as typed on the percept line"))
        return commands

    async def discover(self) -> Hits:
        for name, callback, help_text in self._commands(""):
            yield DiscoveryHit(name, callback, help=help_text)

    async def search(self, query: str) -> Hits:
        matcher = self.matcher(query)
        for name, callback, help_text in self._commands(query):
            score = matcher.match(name)
            if name.startswith("Send percept"):
                score = max(score, 1.0)
            if score > 0:
                yield Hit(score, matcher.highlight(name), callback, help=help_text)
