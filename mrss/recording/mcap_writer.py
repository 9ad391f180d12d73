"""Writes a recording of the bus as MCAP: a channel per topic, JSON against generated schemas.

The layout (docs/tools.md, "The MCAP recording"):

* profile `mrss`; one channel per bus topic (and kind), message encoding `json`, schema
  `mrss.<kind>` (encoding `jsonschema`, mrss/recording/schemas.py). Each message is the
  envelope in JSON; log time is when the recorder received it, publish time the
  envelope's `ts`, sequence its number on the channel. A batch is one message per
  envelope; reliable data is recorded as the message it carries.
* `robot.<id>.location`: Foxglove's `foxglove.LocationFix` for every telemetry record
  with a lat and lon, so Foxglove's Map panel shows the robots without configuration.
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
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

import msgpack
from mcap.writer import CompressionType, Writer

import mrss
from mrss.bus.wire import message_frames
from mrss.recording.format import RecordedMessage
from mrss.recording.schemas import (
    ENCODING,
    LOCATION_FIX,
    LOCATION_FIX_SCHEMA,
    MALFORMED,
    MALFORMED_SCHEMA,
    all_kind_schemas,
    location_fix,
    schema_name,
    to_json,
)

PROFILE = "mrss"
MALFORMED_TOPIC = "mrss.malformed"
CHUNK_BYTES = 1024 * 1024
CHUNK_SECONDS = 1.0
LOCATION_SUFFIX = ".location"
ASL_MEDIA_TYPE = "text/x-agentspeak"


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
        self._mcap = Writer(out, chunk_size=CHUNK_BYTES, compression=CompressionType.ZSTD)
        self._mcap.start(profile=PROFILE, library=f"mrss {mrss.__version__}")
        self._out = out
        self._schemas: dict[str, int] = {}
        self._channels: dict[tuple[str, str], int] = {}
        self._sequence: dict[int, int] = defaultdict(int)
        self._incarnations: dict[str, set[int]] = defaultdict(set)
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

    def _channel(self, topic: str, schema: str, data: dict[str, Any]) -> int:
        key = (topic, schema)
        channel = self._channels.get(key)
        if channel is None:
            schema_id = self._schemas.get(schema)
            if schema_id is None:
                schema_id = self._schemas[schema] = self._mcap.register_schema(
                    schema, ENCODING, json.dumps(data).encode())
            channel = self._channels[key] = self._mcap.register_channel(
                topic, "json", schema_id)
        return channel

    def _add(self, channel: int, log_time: int, publish_time: int, value: Any) -> None:
        self._sequence[channel] += 1
        self._mcap.add_message(channel, log_time=log_time, publish_time=publish_time,
                               data=json.dumps(value, separators=(",", ":")).encode(),
                               sequence=self._sequence[channel])

    def write(self, message: RecordedMessage) -> None:
        """Append one ZeroMQ message as recorded: each envelope in it, or a malformed one."""
        if not message.frames:
            raise ValueError("a recorded message has at least one frame")
        log_time = _ns(message.t)
        if self._chunk_opened is None:
            self._chunk_opened = time.monotonic()
        if message.malformed:
            self.count += 1
            self.malformed += 1
            self._add(self._channel(MALFORMED_TOPIC, MALFORMED_SCHEMA, MALFORMED), log_time,
                      log_time, {"frames": [base64.b64encode(f).decode() for f in message.frames],
                                 "note": message.note})
            return
        for topic, payload in message_frames(list(message.frames)):
            env = msgpack.unpackb(payload, raw=False, strict_map_key=True)
            self._envelope(topic.decode(), env, log_time)

    def _envelope(self, topic: str, env: dict[str, Any], log_time: int) -> None:
        kind = env["kind"]
        name = schema_name(kind)
        publish_time = _ns(float(env["ts"]))
        self._incarnations[env["src"]].add(env["inc"])
        cred = env.get("cred")
        value = to_json(env)
        value.pop("op", None)  # an operator's session credential is a secret: never kept
        if cred is not None:
            value["cred"] = base64.b64encode(cred).decode("ascii")
        self._add(self._channel(topic, name, _KIND_SCHEMAS[name]), log_time, publish_time,
                  value)
        self.count += 1
        if kind == "robot.data":
            body = env["body"]
            fix = location_fix(body["robot"], float(env["ts"]), body["data"])
            if fix is not None:
                self._add(self._channel(f"robot.{body['robot']}{LOCATION_SUFFIX}", LOCATION_FIX,
                                        LOCATION_FIX_SCHEMA), log_time, publish_time, fix)

    def flush(self) -> None:
        """Close the open chunk if it is `CHUNK_SECONDS` old (it then reaches the OS)."""
        opened = self._chunk_opened
        if opened is not None and time.monotonic() - opened >= CHUNK_SECONDS:
            self._mcap.flush()  # type: ignore[no-untyped-call]
            self._chunk_opened = None

    def finish(self) -> None:
        """Close the last chunk, write the incarnations seen and the summary with its index."""
        if self._finished:
            return
        self._finished = True
        self._mcap.add_metadata("incarnations", {
            src: ",".join(map(str, sorted(incs)))
            for src, incs in sorted(self._incarnations.items())
        })
        self._mcap.finish()  # type: ignore[no-untyped-call]
        self._out.flush()


_KIND_SCHEMAS = all_kind_schemas()
