"""Reads an MCAP recording of MRSS (mcap_writer.py), damage reported with its byte offset.

The records are read in file order with the `mcap` library's stream reader, so a file
whose recorder was killed (no summary, a last chunk cut short) is read up to its last
complete chunk; then `RecordingError` names the offset where the damage starts. A file
that is MCAP but not MRSS's (another profile) is refused at the header's offset.
"""

from __future__ import annotations

import base64
import json
import struct
from collections.abc import Iterator
from dataclasses import dataclass
from typing import IO, Any

import msgpack
from mcap.exceptions import EndOfFile, McapError
from mcap.records import Attachment, Channel, Chunk, Footer, Header, Message, Metadata, Schema
from mcap.stream_reader import StreamReader, breakup_chunk

from mrss.recording.format import RecordedMessage, RecordingError
from mrss.recording.mcap_writer import MALFORMED_TOPIC, PROFILE
from mrss.recording.schemas import MALFORMED_SCHEMA, SCHEMA_PREFIX, from_json

MAGIC = b"\x89MCAP0\r\n"


class _Counted:
    """A binary file's reads, counted: `offset` is where the next read starts."""

    def __init__(self, source: IO[bytes]) -> None:
        self._source = source
        self.offset = 0

    def read(self, size: int = -1) -> bytes:
        data = self._source.read(size)
        self.offset += len(data)
        return data


@dataclass(frozen=True)
class McapEntry:
    """One message of the file: its channel's topic and schema name, times (ns), data."""

    topic: str
    schema: str
    log_time: int
    publish_time: int
    data: bytes
    offset: int  # where its chunk (or the message record) starts in the file

    def value(self) -> Any:
        """The message's JSON (ValueError if it is not JSON)."""
        return json.loads(self.data)


class McapRecording:
    """An MRSS MCAP recording read from `source` in file order (one pass).

    The constructor checks the magic and the header (`RecordingError` at offset 0 or 8).
    Iterate `entries()`; `metadata` and `attachments` fill as they are passed (the
    project's at the start, the incarnations at the end); `complete` tells whether the
    file's end (its footer) was reached.
    """

    def __init__(self, source: IO[bytes]) -> None:
        magic = source.read(len(MAGIC))
        if magic != MAGIC:
            raise RecordingError("not an MCAP file (bad magic)", offset=0)
        self._in = _Counted(source)
        self._in.offset = len(MAGIC)
        stream: Any = self._in  # a file object as far as the reader goes: it only reads
        self._records = StreamReader(stream, skip_magic=True, emit_chunks=True).records
        header = self._next()
        if not isinstance(header, Header):
            raise RecordingError("an MCAP file without its header", offset=len(MAGIC))
        if header.profile != PROFILE:
            raise RecordingError(
                f"an MCAP file, but not an MRSS recording (profile {header.profile!r}, "
                f"written by {header.library!r}; MRSS writes profile {PROFILE!r})",
                offset=len(MAGIC))
        self.library = header.library
        self.metadata: dict[str, dict[str, str]] = {}
        self.attachments: dict[str, bytes] = {}
        self.complete = False
        self._schemas: dict[int, str] = {}
        self._channels: dict[int, tuple[str, str]] = {}  # id -> (topic, schema name)

    def _next(self) -> Any:
        """The next record (None at the end of the stream); damage as RecordingError."""
        start = self._in.offset
        try:
            return next(self._records)
        except StopIteration:
            return None
        except EndOfFile:
            if self._in.offset == start:
                return None  # the file ends between two records
            raise RecordingError(_reason(EndOfFile(), start), offset=start) from None
        except (McapError, struct.error, ValueError, UnicodeDecodeError, MemoryError) as exc:
            raise RecordingError(_reason(exc, self._in.offset), offset=start) from None

    def entries(self) -> Iterator[McapEntry]:
        """Every message in file order, then RecordingError if the file is damaged or cut."""
        while True:
            start = self._in.offset
            record = self._next()
            if record is None:
                if not self.complete:
                    raise RecordingError("the file ends before its footer (the recorder did "
                                         "not finish): truncated", offset=start)
                return
            if isinstance(record, Chunk):
                try:
                    inner = breakup_chunk(record, validate_crc=True)
                except Exception as exc:  # zstd, lz4 and struct raise many kinds for garbage
                    raise RecordingError(f"corrupt chunk: {_reason(exc, start)}",
                                         offset=start) from None
                for item in inner:
                    entry = self._take(item, start)
                    if entry is not None:
                        yield entry
            else:
                entry = self._take(record, start)
                if entry is not None:
                    yield entry

    def _take(self, record: Any, offset: int) -> McapEntry | None:
        if isinstance(record, Message):
            channel = self._channels.get(record.channel_id)
            if channel is None:
                raise RecordingError(f"a message on unknown channel {record.channel_id}",
                                     offset=offset)
            return McapEntry(channel[0], channel[1], record.log_time, record.publish_time,
                             bytes(record.data), offset)
        if isinstance(record, Schema):
            self._schemas[record.id] = record.name
        elif isinstance(record, Channel):
            self._channels[record.id] = (record.topic, self._schemas.get(record.schema_id, ""))
        elif isinstance(record, Metadata):
            self.metadata[record.name] = dict(record.metadata)
        elif isinstance(record, Attachment):
            self.attachments[record.name] = bytes(record.data)
        elif isinstance(record, Footer):
            self.complete = True
        return None

    def recorded(self) -> Iterator[RecordedMessage]:
        """The bus messages, as `mrss replay` publishes them: `[topic, msgpack envelope]`
        (malformed ones with their recorded frames and reason). Channels MRSS derived
        (LocationFix) are left out; a message that is not an envelope in JSON raises
        RecordingError at its chunk's offset."""
        for entry in self.entries():
            message = recorded_message(entry)
            if message is not None:
                yield message


def recorded_message(entry: McapEntry) -> RecordedMessage | None:
    """One MCAP message of a recording as the bus message it recorded (`recorded`); None
    for a channel MRSS derived (LocationFix, GeoJSON)."""
    if entry.schema == MALFORMED_SCHEMA and entry.topic == MALFORMED_TOPIC:
        value = _json(entry)
        frames = tuple(base64.b64decode(f) for f in value["frames"])
        return RecordedMessage(entry.log_time / 1e9, frames, value["note"] or "malformed",
                               entry.offset)
    if not entry.schema.startswith(SCHEMA_PREFIX):
        return None
    env = from_json(_json(entry))
    if not isinstance(env, dict):
        raise RecordingError(f"a message on {entry.topic!r} is not an envelope",
                             offset=entry.offset)
    if isinstance(env.get("cred"), str):
        env["cred"] = base64.b64decode(env["cred"])
    payload = msgpack.packb(env, use_bin_type=True)
    return RecordedMessage(entry.log_time / 1e9, (entry.topic.encode(), payload), "",
                           entry.offset)


def _json(entry: McapEntry) -> Any:
    try:
        return entry.value()
    except ValueError:
        raise RecordingError(f"a message on {entry.topic!r} is not JSON",
                             offset=entry.offset) from None


def _reason(exc: BaseException, offset: int) -> str:
    """What a library exception says about the damage, in words."""
    name = type(exc).__name__
    if name == "EndOfFile" or isinstance(exc, struct.error):
        return "truncated record (the file ends inside it)"
    if name == "CRCValidationError":
        return "checksum mismatch"
    if name == "RecordLengthLimitExceeded":
        return "corrupt record: its length is beyond the file's"
    text = str(exc).strip()
    return f"corrupt record ({name}{': ' + text[:120] if text else ''})"
