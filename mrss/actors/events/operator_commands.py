"""The project's declared operator commands, turned into percepts by the events manager.

For every `[operator.commands.NAME]` of project.toml (`mrss.config.operator_commands`)
the events manager reads the command's topic: a JSON object whose fields fit the
declaration becomes the declared percept (`exclusion_zone(z1, [[..], ..])`); anything
else (a field out of range, a self-intersecting polygon, too many vertices, an unknown
field) is a bad payload, refused back to the sender on `<topic>/reply` and counted,
never a percept. The dashboard checks the same before it sends; this is the check that
holds for every client. Runs beside the project's own adapter, on its MQTT client.

With users configured (mrss.auth), every operator command's topic — these and the
fixed vocabulary's (`[operator] area = ...`) — needs a `"credential"` in its JSON whose
role may send it (`operator_check`, before the project's own handler sees it).
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

from mrss.actors.events.adapter import ExternalAdapter
from mrss.auth.roles import CommandKind, Role
from mrss.auth.sessions import CREDENTIAL_KEY
from mrss.config.loader import load_file
from mrss.config.operator import SECTION, OperatorCommand, read_operator
from mrss.config.operator_commands import CommandError, CommandSpec
from mrss.config.projects import PROJECT_FILE
from mrss.edge.payloads import PayloadError, decode_json_object
from mrss.runtime.operator_guard import OperatorGuard


def declared_commands(project_dir: Path) -> dict[str, CommandSpec]:
    """The project's declared commands (none without `[operator.commands]`)."""
    file = project_dir / PROJECT_FILE
    if not file.is_file():
        return {}
    sections = load_file(file).sections
    if SECTION not in sections:
        return {}
    return read_operator(sections[SECTION], file=str(file)).commands


def serve_commands(adapter: ExternalAdapter, commands: dict[str, CommandSpec]) -> None:
    """Subscribe the adapter's MQTT client to every command's topic."""
    for spec in commands.values():
        adapter.on_json(spec.topic, _handler(adapter, spec))


def _handler(adapter: ExternalAdapter, spec: CommandSpec) -> Any:
    def handle(topic: str, obj: dict[str, Any]) -> None:
        try:
            literal = spec.literal(obj)
        except CommandError as exc:
            raise PayloadError(f"{spec.name}: {exc}", topic=topic) from None
        adapter.percept(literal)
    return handle


def operator_topics(project_dir: Path) -> dict[str, tuple[CommandKind, Role | None]]:
    """Every operator command's MQTT topic -> the kind and least role it needs: the fixed
    vocabulary's (`[operator] area = ...`; teleop is `TELEOP`, the others `MISSION`) and
    the declared commands' (their `role`)."""
    file = project_dir / PROJECT_FILE
    if not file.is_file():
        return {}
    sections = load_file(file).sections
    if SECTION not in sections:
        return {}
    config = read_operator(sections[SECTION], file=str(file))
    topics: dict[str, tuple[CommandKind, Role | None]] = {
        topic: (CommandKind.TELEOP if command is OperatorCommand.TELEOP
                else CommandKind.MISSION, None)
        for command, topic in config.topics.items()}
    for spec in config.commands.values():
        topics[spec.topic] = (CommandKind.MISSION, Role(spec.role))
    return topics


def operator_check(guard: OperatorGuard, topics: dict[str, tuple[CommandKind, Role | None]]
                   ) -> Callable[[str, bytes], bytes]:
    """The check of an operator command's author, run before its handler: the payload
    without its `"credential"`, or PayloadError (refused back to the sender, counted)
    when the sender's role may not send it. Other topics pass untouched."""

    def check(topic: str, payload: bytes) -> bytes:
        wanted = topics.get(topic)
        if wanted is None or not guard.active:
            return payload
        obj = decode_json_object(payload, topic=topic)
        credential = obj.pop(CREDENTIAL_KEY, "")
        verdict = guard.check(credential if isinstance(credential, str) else "",
                              wanted[0], topic, least=wanted[1], sender=f"mqtt:{topic}")
        if not verdict.ok:
            raise PayloadError(f"refused: {verdict.reason}", topic=topic)
        return json.dumps(obj).encode()
    return check
