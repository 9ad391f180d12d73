"""The mission panel's way to the agent: the project's operator commands, sent as its
operator UI sends them.

A command declared in `[operator]` (`mrss.config.operator`) is JSON published on the
project's MQTT broker (`[broker] url`, else the embedded broker's `<run_dir>/broker.url`)
and sent again until the events manager answers on `<topic>/reply`
(`mrss.api.request_json`); the events manager turns it into a percept, so the agent
decides what happens (a cancelled goal is cancelled by the agent's own plan, not failed
under it). `send` blocks: the app calls it on a worker thread.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mrss.auth.sessions import CREDENTIAL_KEY
from mrss.config.map import SECTION as MAP_SECTION
from mrss.config.map import MapConfig, read_map
from mrss.config.operator import SECTION, OperatorCommand, OperatorConfig, read_operator
from mrss.config.operator_commands import CommandSpec
from mrss.errors import MrssError

ACCEPTED = ("accepted", "duplicate")


@dataclass(frozen=True)
class Answer:
    """What the events manager said (or why nothing was sent)."""

    ok: bool
    text: str


class MissionChannel:
    """Sends the project's operator commands to its events manager."""

    def __init__(self, config: OperatorConfig, broker: Callable[[], str | None], *,
                 patience: float = 10.0, client_id: str = "") -> None:
        self.config = config
        self._broker = broker
        self.patience = patience
        # unique per dashboard: two MQTT clients with one id throw each other off
        self.client_id = client_id or f"mrss-tui-{os.getpid()}"
        self.sent = 0
        self.credential = ""  # the logged-in operator's (mrss.tui.login), sent with each

    @classmethod
    def for_project(cls, config: OperatorConfig, project_dir: Path | None,
                    run_dir: Path | None, **kwargs: Any) -> MissionChannel:
        """The broker is looked up at each send: the embedded one writes its address late."""
        from mrss.links.connect import project_broker_url  # the robot links: only if needed

        return cls(config, lambda: project_broker_url(project_dir, run_dir), **kwargs)

    def topic(self, command: OperatorCommand | CommandSpec) -> str | None:
        if isinstance(command, CommandSpec):
            return command.topic
        return self.config.topics.get(command)

    def send(self, command: OperatorCommand | CommandSpec, payload: dict[str, Any]) -> Answer:
        """Publish one command (the fixed vocabulary's, or one the project declares in
        `[operator.commands]`) until it is answered; never raises."""
        topic = self.topic(command)
        if topic is None:
            name = command.name if isinstance(command, CommandSpec) else command.value
            return Answer(False, f"this project declares no {name} command "
                                 f"([operator] {name} in project.toml)")
        broker = self._broker()
        if not broker:
            return Answer(False, "no MQTT broker known ([broker] url, or the embedded "
                                 "broker's broker.url in the run dir)")
        self.sent += 1
        from mrss.links.mqtt_request import request_json

        if self.credential:  # checked by the events manager (mrss.runtime.operator_guard)
            payload = {**payload, CREDENTIAL_KEY: self.credential}
        try:
            answer = request_json(broker, topic, payload, client_id=f"{self.client_id}-"
                                  f"{self.sent}", within=min(5.0, self.patience),
                                  patience=self.patience)
        except (MrssError, OSError) as exc:
            return Answer(False, f"{topic}: {exc}")
        status = str(answer.get("status", "?"))
        reason = f": {answer['reason']}" if answer.get("reason") else ""
        return Answer(status in ACCEPTED, f"{topic} {status}{reason}")


def project_mission(project_dir: Path, file: Path, sections: dict[str, Any],
                    run_dir: Path | None) -> MissionChannel | None:
    """The channel of a project that declares `[operator]`, else None; ConfigError if the
    table is wrong (`mrss check` says the same, with the line)."""
    if SECTION not in sections:
        return None
    config = read_operator(sections[SECTION], file=str(file))
    return MissionChannel.for_project(config, project_dir, run_dir)


def project_map(file: Path, sections: dict[str, Any]) -> MapConfig:
    """The project's `[map]` styles (defaults without the table); ConfigError if the
    table is wrong (`mrss check` says the same, with the line)."""
    return read_map(sections.get(MAP_SECTION), file=str(file))


def run_dir_of(backend: str) -> Path | None:
    """The run dir of ipc bus endpoints (`ipc:///run/dir/bus-sub.sock`), else None."""
    if not backend.startswith("ipc://"):
        return None
    return Path(backend[len("ipc://"):]).parent
