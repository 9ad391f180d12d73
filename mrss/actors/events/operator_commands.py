"""The project's declared operator commands, turned into percepts by the events manager.

For every `[operator.commands.NAME]` of project.toml (`mrss.config.operator_commands`)
the events manager reads the command's topic: a JSON object whose fields fit the
declaration becomes the declared percept (`exclusion_zone(z1, [[..], ..])`); anything
else (a field out of range, a self-intersecting polygon, too many vertices, an unknown
field) is a bad payload, refused back to the sender on `<topic>/reply` and counted,
never a percept. The dashboard checks the same before it sends; this is the check that
holds for every client. Runs beside the project's own adapter, on its MQTT client.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from mrss.actors.events.adapter import ExternalAdapter
from mrss.config.loader import load_file
from mrss.config.operator import SECTION, read_operator
from mrss.config.operator_commands import CommandError, CommandSpec
from mrss.config.projects import PROJECT_FILE
from mrss.edge.payloads import PayloadError


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
