"""Writes a recording of the bus as MCAP: a channel per topic, JSON against generated schemas.

The layout (docs/tools.md, "The MCAP recording"):

* profile `mrss`; one channel per bus topic (and kind), message encoding `json`, schema
  `mrss.<kind>` (encoding `jsonschema`, mrss/recording/schemas.py). Each message is the
  envelope in JSON; log time is when the recorder received it, publish time the
  envelope's `ts`, sequence its number on the channel. A batch is one message per
  envelope; reliable data is recorded as the message it carries.
* `robot.<id>.location`: Foxglove's `foxglove.LocationFix` for every `position` record
  (or untyped sample) with a lat and lon (`schemas.location_fix`), so Foxglove's Map
  panel shows the robots without configuration.
* `world.geojson`: the world model's areas, zones and objects (not robots) as Foxglove's
  `foxglove.GeoJSON`, written whole each time they change as the bus shows them
  (mrss/recording/geojson.py).
* `mrss.malformed`: what did not decode, its frames in base64 and the reason.
* metadata `mrss` (version, creation time, bus endpoints, prefixes), `project` (its name
  and project.toml) at the start, `incarnations` (every sender's incarnations seen) at
  the end; the project's AgentSpeak files as attachments.

Chunks are zstd-compressed, closed at `CHUNK_BYTES` or `CHUNK_SECONDS` after their first
message, whichever comes first, and written out then: a recorder killed leaves a file
readable up to its last complete chunk. `finish` writes the summary and its index
(seeking by time without reading the data).
"""

from __future__ import annotations

import base64
import json
import time
from collections import defaultdict
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

from mcap.writer import CompressionType

import mrss
from mrss.bus.wire import RELIABLE_PREFIX, message_frames
from mrss.errors import DecodeError
from mrss.messages import DataReply, DataRequest, Envelope, RobotData
from mrss.recording.format import RecordedMessage
from mrss.recording.geojson import GEOJSON, GEOJSON_SCHEMA, GEOJSON_TOPIC, WorldShapes
from mrss.recording.mcap_fast import FastWriter
from mrss.recording.schemas import (
    ENCODING,
    LOCATION_FIX,
    LOCATION_FIX_SCHEMA,
    MALFORMED,
    MALFORMED_SCHEMA,
    SCHEMA_PREFIX,
    all_kind_schemas,
    json_bytes,
    location_fix_json,
)
from mrss.recording.transcode import recording_json

PROFILE = "mrss"
MALFORMED_TOPIC = "mrss.malformed"
# 256 KiB of messages a chunk (before compression): a seek decompresses and parses one
# chunk (1 MiB ones cost four times as long to seek in, `mrss bench record`), and zstd
# compresses 256 KiB as well as 1 MiB.
CHUNK_BYTES = 256 * 1024
CHUNK_SECONDS = 1.0
LOCATION_SUFFIX = ".location"
ASL_MEDIA_TYPE = "text/x-agentspeak"


class _Channel:
    """An MCAP channel of the file and the sequence number of its last message."""

    __slots__ = ("id", "sequence")

    def __init__(self, channel_id: int) -> None:
        self.id = channel_id
        self.sequence = 0


@dataclass(frozen=True)
class ProjectFiles:
    """What a recording keeps of the project it recorded: its name, project.toml, agents."""

    name: str
    project_toml: str
    agents: dict[str, bytes] = field(default_factory=dict)  # file name -> AgentSpeak source

    @classmethod
    def read(cls, folder: Path) -> ProjectFiles:
        """The project in `folder` (OSError if its project.toml cannot be read)."""
        agents = {p.name: p.read_bytes() for p in sorted(folder.glob("*.asl"))}
        return cls(folder.name, (folder / "project.toml").read_text(encoding="utf-8"), agents)


def _ns(seconds: float) -> int:
    return max(0, int(seconds * 1e9))


class McapRecordingWriter:
    """What a recorder writes to (`write`, `flush`, `count`, `malformed`), as MCAP.

    `flush` closes the open chunk once it is `CHUNK_SECONDS` old; `finish` closes the
    file's summary. Call `finish` before closing `out`.
    """

    def __init__(self, out: IO[bytes], *, created: float,
                 endpoints: dict[str, str] | None = None, prefixes: list[str] | None = None,
                 project: ProjectFiles | None = None) -> None:
        self._mcap = FastWriter(out, chunk_size=CHUNK_BYTES, compression=CompressionType.ZSTD)
        self._mcap.start(profile=PROFILE, library=f"mrss {mrss.__version__}")
        self._out = out
        self._schemas: dict[str, int] = {}
        self._channels: dict[tuple[str, str], _Channel] = {}  # by topic and schema name
        self._by_kind: dict[tuple[str, type], _Channel] = {}  # by topic and message kind
        self._fixes: dict[str, _Channel] = {}  # a robot's LocationFix channel
        self._senders: set[tuple[str, int]] = set()  # (src, incarnation) seen
        self._world = WorldShapes()
        self._chunk_opened: float | None = None
        self._finished = False
        self.count = 0  # bus messages written: each envelope of a batch, and malformed ones
        self.malformed = 0
        self._mcap.add_metadata("mrss", {
            "version": mrss.__version__, "created": repr(float(created)),
            "endpoints": json.dumps(endpoints or {}), "prefixes": json.dumps(prefixes or [""]),
        })
        if project is not None:
            self._mcap.add_metadata("project", {"name": project.name,
                                                "project.toml": project.project_toml})
            stamp = _ns(created)
            for name, source in project.agents.items():
                self._mcap.add_attachment(create_time=stamp, log_time=stamp, name=name,
                                          media_type=ASL_MEDIA_TYPE, data=source)
        out.flush()

    def _channel(self, topic: str, schema: str, data: dict[str, Any]) -> _Channel:
        key = (topic, schema)
        channel = self._channels.get(key)
        if channel is None:
            schema_id = self._schemas.get(schema)
            if schema_id is None:
                schema_id = self._schemas[schema] = self._mcap.register_schema(
                    schema, ENCODING, json.dumps(data).encode())
            channel = self._channels[key] = _Channel(self._mcap.register_channel(
                topic, "json", schema_id))
        return channel

    def _add(self, channel: _Channel, log_time: int, publish_time: int, data: bytes) -> None:
        channel.sequence += 1
        self._mcap.add_message(channel.id, log_time, data, publish_time, channel.sequence)

    def received(self, t: float, frames: list[bytes]) -> None:
        """Check and write one ZeroMQ message as a recorder received it at `t` (Unix s):
        each envelope in it, or, when any of them does not decode, the whole message as
        malformed with the reason. Each envelope is unpacked once, for both."""
        try:
            if len(frames) == 2 and not frames[0].startswith(RELIABLE_PREFIX):
                data, envelope = recording_json(frames[0], frames[1])  # the common case
                if self._chunk_opened is None:
                    self._chunk_opened = time.monotonic()
                self._envelope(data, envelope, int(t * 1e9) if t > 0 else 0)
                return
            decoded = [recording_json(topic, payload)
                       for topic, payload in message_frames(frames)]
        except DecodeError as exc:
            self._malformed(t, frames, exc.reason)
            return
        log_time = _ns(t)
        if self._chunk_opened is None:
            self._chunk_opened = time.monotonic()
        for data, envelope in decoded:
            self._envelope(data, envelope, log_time)

    def write(self, message: RecordedMessage) -> None:
        """Append one ZeroMQ message as recorded: each envelope in it, or a malformed one
        (what its note says, or what does not decode)."""
        if not message.frames:
            raise ValueError("a recorded message has at least one frame")
        if message.malformed:
            self._malformed(message.t, message.frames, message.note)
        else:
            self.received(message.t, list(message.frames))

    def _malformed(self, t: float, frames: Sequence[bytes], note: str) -> None:
        if self._chunk_opened is None:
            self._chunk_opened = time.monotonic()
        self.count += 1
        self.malformed += 1
        log_time = _ns(t)
        self._add(self._channel(MALFORMED_TOPIC, MALFORMED_SCHEMA, MALFORMED), log_time,
                  log_time, json_bytes({"frames": [base64.b64encode(f).decode() for f in frames],
                                        "note": note}))

    def _envelope(self, data: bytes, envelope: Envelope, log_time: int) -> None:
        # the recorder's time per message is mostly here: one pass, nothing looked up twice
        body = envelope.body
        kind = type(body)
        ts = envelope.ts
        publish_time = int(ts * 1e9) if ts > 0 else 0
        self._senders.add((envelope.src, envelope.inc))
        channel = self._by_kind.get((envelope.topic, kind))
        if channel is None:
            name = SCHEMA_PREFIX + body.kind
            channel = self._by_kind[envelope.topic, kind] = self._channel(
                envelope.topic, name, _KIND_SCHEMAS[name])
        channel.sequence += 1
        add = self._mcap.add_message
        add(channel.id, log_time, data, publish_time, channel.sequence)
        self.count += 1
        if kind is RobotData:
            assert isinstance(body, RobotData)  # for mypy
            fix = location_fix_json(body.robot, ts, body.data)
            if fix is not None:
                channel = self._fixes.get(body.robot)
                if channel is None:
                    channel = self._fixes[body.robot] = self._channel(
                        f"robot.{body.robot}{LOCATION_SUFFIX}", LOCATION_FIX,
                        LOCATION_FIX_SCHEMA)
                channel.sequence += 1
                add(channel.id, log_time, fix, publish_time, channel.sequence)
        elif (kind is DataRequest or kind is DataReply) \
                and self._world.seen(envelope.topic, body):
            self._add(self._channel(GEOJSON_TOPIC, GEOJSON, GEOJSON_SCHEMA), log_time,
                      publish_time, json_bytes(self._world.collection()))

    def flush(self) -> None:
        """Close the open chunk if it is `CHUNK_SECONDS` old (it then reaches the OS)."""
        opened = self._chunk_opened
        if opened is not None and time.monotonic() - opened >= CHUNK_SECONDS:
            self._mcap.flush()
            self._chunk_opened = None

    def finish(self) -> None:
        """Close the last chunk, write the incarnations seen and the summary with its index."""
        if self._finished:
            return
        self._finished = True
        incarnations: dict[str, list[int]] = defaultdict(list)
        for src, inc in sorted(self._senders):
            incarnations[src].append(inc)
        self._mcap.add_metadata("incarnations", {
            src: ",".join(map(str, incs)) for src, incs in incarnations.items()})
        self._mcap.finish()
        self._out.flush()


_KIND_SCHEMAS = all_kind_schemas()
