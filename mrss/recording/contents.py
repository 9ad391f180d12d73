"""What an MCAP recording holds, for `mrss recording info` and `export`: channels and
their counts, time span, project, incarnations; its messages by topic prefix as rows.

Both read the file once in order (mcap_reader.py), so a cut or damaged file gives what
comes before the damage, and `damage` (a RecordingError with the offset) says where.
"""

from __future__ import annotations

import csv
import json
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import IO, Any

from mrss.recording.format import RecordingError
from mrss.recording.mcap_reader import McapEntry, McapRecording


@dataclass
class ChannelCount:
    topic: str
    schema: str
    count: int = 0


@dataclass
class Contents:
    """A recording's table of contents, as far as it could be read."""

    library: str
    channels: dict[tuple[str, str], ChannelCount] = field(default_factory=dict)
    first: int | None = None  # log time (ns) of the first and last message
    last: int | None = None
    metadata: dict[str, dict[str, str]] = field(default_factory=dict)
    attachments: list[str] = field(default_factory=list)
    complete: bool = False
    damage: RecordingError | None = None

    @property
    def messages(self) -> int:
        return sum(c.count for c in self.channels.values())


def contents(source: IO[bytes]) -> Contents:
    """Read all of `source` (RecordingError at once if it is not an MRSS MCAP file)."""
    recording = McapRecording(source)
    found = Contents(recording.library)
    try:
        for entry in recording.entries():
            key = (entry.topic, entry.schema)
            channel = found.channels.get(key)
            if channel is None:
                channel = found.channels[key] = ChannelCount(entry.topic, entry.schema)
            channel.count += 1
            if found.first is None or entry.log_time < found.first:
                found.first = entry.log_time
            if found.last is None or entry.log_time > found.last:
                found.last = entry.log_time
    except RecordingError as exc:
        found.damage = exc
    found.metadata = recording.metadata
    found.attachments = sorted(recording.attachments)
    found.complete = recording.complete
    return found


def matching(recording: McapRecording, prefix: str) -> Iterator[McapEntry]:
    """The messages on topics starting with `prefix`, in file order."""
    for entry in recording.entries():
        if entry.topic.startswith(prefix):
            yield entry


def _row(entry: McapEntry) -> dict[str, Any]:
    try:
        message = entry.value()
    except ValueError:
        raise RecordingError(f"a message on {entry.topic!r} is not JSON",
                             offset=entry.offset) from None
    return {"topic": entry.topic, "log_time": entry.log_time / 1e9,
            "publish_time": entry.publish_time / 1e9, "message": message}


def export_jsonl(recording: McapRecording, prefix: str, out: IO[str]) -> int:
    """One JSON object a line: topic, log_time, publish_time (Unix s), message; the count."""
    count = 0
    for entry in matching(recording, prefix):
        out.write(json.dumps(_row(entry), separators=(",", ":")) + "\n")
        count += 1
    return count


def flatten(value: Any, into: dict[str, Any], name: str = "") -> None:
    """A message's fields as columns: maps by dotted names, lists as JSON text."""
    if isinstance(value, dict):
        for key, item in value.items():
            flatten(item, into, f"{name}.{key}" if name else str(key))
    elif isinstance(value, list):
        into[name] = json.dumps(value, separators=(",", ":"))
    else:
        into[name] = value


def export_csv(source: IO[bytes], prefix: str, out: IO[str]) -> int:
    """A header row of every column seen, then one row a message; the count.

    Two passes over `source` (the columns first), so it must be seekable.
    """
    start = source.tell()
    columns: dict[str, None] = {"topic": None, "log_time": None, "publish_time": None}
    for entry in matching(McapRecording(source), prefix):
        cells: dict[str, Any] = {}
        flatten(_row(entry)["message"], cells)
        columns.update(dict.fromkeys(cells))
    source.seek(start)
    writer = csv.DictWriter(out, fieldnames=list(columns), extrasaction="ignore")
    writer.writeheader()
    count = 0
    for entry in matching(McapRecording(source), prefix):
        row = _row(entry)
        cells = {"topic": row["topic"], "log_time": row["log_time"],
                 "publish_time": row["publish_time"]}
        flatten(row["message"], cells)
        writer.writerow(cells)
        count += 1
    return count
