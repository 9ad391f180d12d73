"""The bus as Foxglove channels: what a recording writes, sent live instead of to a file.

`FoxgloveBridge` is a recorder's writer (`mrss.recording.recorder.Writer`): the bus
recorder hands it every bus message, frames untouched, and it logs each one on a
Foxglove SDK channel exactly as the MCAP recording lays it out (mrss/recording/
mcap_writer.py): a channel per bus topic and kind, the envelope in JSON against the
kind's schema `mrss.<kind>` (encoding `jsonschema`); `robot.<id>.location` as Foxglove's
`foxglove.LocationFix` for every record of the robot's position, so the Map panel
shows the robots; `mrss.malformed` for what did not decode. A test writes the same
messages both ways and compares the channels, schemas and data.

Channels are made when their first message comes (the server then advertises them).
Each message is turned into JSON by the recorder's own code (mrss/recording/
transcode.py), so the live channels carry the recording's bytes: an operator's session
credential (`op`) is never sent.
"""

from __future__ import annotations

import base64
import json
from collections.abc import Sequence
from typing import Any

import foxglove

from mrss.bus.wire import message_frames
from mrss.errors import DecodeError
from mrss.messages import Envelope, RobotData
from mrss.recording.format import RecordedMessage
from mrss.recording.mcap_writer import LOCATION_SUFFIX, MALFORMED_TOPIC
from mrss.recording.schemas import (
    ENCODING,
    LOCATION_FIX,
    LOCATION_FIX_SCHEMA,
    MALFORMED,
    MALFORMED_SCHEMA,
    all_kind_schemas,
    json_bytes,
    location_fix_json,
    schema_name,
)
from mrss.recording.transcode import recording_json

_KIND_SCHEMAS = all_kind_schemas()


def _ns(seconds: float) -> int:
    return max(0, int(seconds * 1e9))


class FoxgloveBridge:
    """Logs bus messages on the channels of `context` (a Foxglove server's)."""

    def __init__(self, context: foxglove.Context) -> None:
        self._context = context
        self._channels: dict[tuple[str, str], foxglove.Channel] = {}
        self.count = 0  # bus messages taken
        self.sent = 0  # messages logged to a subscribed channel

    def channel(self, topic: str, schema: str, data: dict[str, Any]) -> foxglove.Channel:
        """The channel of `topic` and `schema`, made (and advertised) on first use."""
        key = (topic, schema)
        found = self._channels.get(key)
        if found is None:
            found = self._channels[key] = foxglove.Channel(
                topic, schema=foxglove.Schema(name=schema, encoding=ENCODING,
                                              data=json.dumps(data).encode()),
                message_encoding="json", context=self._context)
        return found

    def topics(self) -> list[tuple[str, str]]:
        """(topic, schema name) of every channel made so far."""
        return list(self._channels)

    def _log(self, channel: foxglove.Channel, log_time: int, data: bytes) -> None:
        if channel.has_sinks():
            channel.log(data, log_time=log_time)
            self.sent += 1

    def write(self, message: RecordedMessage) -> None:
        """One ZeroMQ message from the bus: each envelope in it, or a malformed one."""
        if message.malformed:
            self.count += 1
            self._malformed(_ns(message.t), message.frames, message.note)
        else:
            self.received(message.t, list(message.frames))

    def received(self, t: float, frames: list[bytes]) -> None:
        """Check and send one ZeroMQ message as the recorder received it at `t`: each
        envelope in it, or the whole message as malformed with the reason (as the MCAP
        writer does; the recorder then leaves the checking to this)."""
        self.count += 1
        try:
            decoded = [recording_json(topic, payload)
                       for topic, payload in message_frames(frames)]
        except DecodeError as exc:
            self._malformed(_ns(t), frames, exc.reason)
            return
        for data, envelope in decoded:
            self._envelope(data, envelope, _ns(t))

    def _malformed(self, log_time: int, frames: Sequence[bytes], note: str) -> None:
        self._log(self.channel(MALFORMED_TOPIC, MALFORMED_SCHEMA, MALFORMED), log_time,
                  json_bytes({"frames": [base64.b64encode(f).decode() for f in frames],
                              "note": note}))

    def _envelope(self, data: bytes, envelope: Envelope, log_time: int) -> None:
        name = schema_name(envelope.body.kind)
        self._log(self.channel(envelope.topic, name, _KIND_SCHEMAS[name]), log_time, data)
        body = envelope.body
        if isinstance(body, RobotData):
            fix = location_fix_json(body.robot, envelope.ts, body.data)
            if fix is not None:
                self._log(self.channel(f"robot.{body.robot}{LOCATION_SUFFIX}", LOCATION_FIX,
                                       LOCATION_FIX_SCHEMA), log_time, fix)

    def flush(self) -> None:
        """Nothing kept back: each message went out as it came."""
