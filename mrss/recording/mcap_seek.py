"""Seeking in a finished MCAP recording by time, through its summary's chunk index.

The `mcap` library's indexed reader puts every chunk after the time into a heap, then
every message of the first one, before it gives one message: on a 1 GB recording
(16,000 chunks) that was a 478 ms p99 seek on a loaded machine (`mrss bench record`).
`IndexedRecording` keeps the chunk index sorted by start time with the running maximum
of end times, so the chunk that holds the first message at or after a time is found by
bisection; it reads and decompresses that one chunk, and the next ones only as the
reader goes on (or where chunks overlap in time, which a clock stepping back makes
possible: they are merged, so messages come in log-time order all the same).

Opening reads the summary with one `struct` call per chunk index (the library parses
each record field by field: a second for a 1 GB file's 16,000 chunks).
"""

from __future__ import annotations

import bisect
import heapq
import io
import itertools
import struct
import zlib
from collections.abc import Iterator, Sequence
from typing import IO, NamedTuple, overload

import zstandard
from mcap.data_stream import ReadDataStream
from mcap.exceptions import McapError
from mcap.records import Channel, Metadata, MetadataIndex, Schema, Statistics

from mrss.recording.format import RecordingError
from mrss.recording.mcap_reader import MAGIC, McapEntry
from mrss.recording.mcap_writer import PROFILE

_HEADER, _FOOTER, _SCHEMA, _CHANNEL, _CHUNK_INDEX, _STATISTICS = 0x01, 0x02, 0x03, 0x04, 0x08, 0x0B
_METADATA, _METADATA_INDEX = 0x0C, 0x0D
_FOOTER_RECORD = 1 + 8 + 8 + 8 + 4  # opcode, length, summary start, offsets start, crc
_CHUNK_SPAN = struct.Struct("<QQQQ")  # a Chunk Index's start, end, offset and length
_CHUNK_HEAD = struct.Struct("<BQQQQIIs")  # up to the compression name's first byte
_RECORD_HEAD = struct.Struct("<BQ")
_MESSAGE_HEAD = struct.Struct("<HIQQ")  # channel, sequence, log time, publish time
_MESSAGE = 0x05
_Pending = tuple[int, int, int, list[tuple[int, int]], bytes, int]


class IndexedRecording:
    """A finished MRSS MCAP recording, opened by its summary (seekable `source`).

    The constructor reads the footer and the summary (RecordingError with the offset if
    the file is not an MRSS recording, or has no summary: a recorder that did not
    finish; such a file is read in order with `McapRecording`).
    """

    def __init__(self, source: IO[bytes]) -> None:
        self._source = source
        size = source.seek(0, io.SEEK_END)
        source.seek(0)
        if source.read(len(MAGIC)) != MAGIC:
            raise RecordingError("not an MCAP file (bad magic)", offset=0)
        header = self._record(len(MAGIC), _HEADER)
        (profile_length,) = struct.unpack_from("<I", header)
        profile = header[4:4 + profile_length].decode("utf-8", "replace")
        if profile != PROFILE:
            raise RecordingError(f"an MCAP file, but not an MRSS recording (profile "
                                 f"{profile!r})", offset=len(MAGIC))
        footer_at = size - len(MAGIC) - _FOOTER_RECORD
        footer = self._record(footer_at, _FOOTER) if footer_at > len(MAGIC) else b""
        summary_start, offsets_start = struct.unpack_from("<QQ", footer) \
            if len(footer) >= 16 else (0, 0)
        if summary_start == 0 or not len(MAGIC) < summary_start <= footer_at:
            raise RecordingError("the file has no summary (the recorder did not finish): "
                                 "read it in order", offset=size)
        source.seek(summary_start)
        summary = source.read((offsets_start or footer_at) - summary_start)
        self._chunks: list[_Chunk] = []
        schemas: dict[int, str] = {}
        channels: dict[int, tuple[str, int]] = {}
        stats: Statistics | None = None
        self._metadata_at: dict[str, tuple[int, int]] = {}  # name -> offset, length
        try:
            for opcode, body in _records(summary):
                if opcode == _CHUNK_INDEX:
                    self._chunks.append(_chunk_index(body))
                elif opcode == _SCHEMA:
                    schema = Schema.read(ReadDataStream(io.BytesIO(body)))
                    schemas[schema.id] = schema.name
                elif opcode == _CHANNEL:
                    channel = Channel.read(ReadDataStream(io.BytesIO(body)))
                    channels[channel.id] = (channel.topic, channel.schema_id)
                elif opcode == _STATISTICS:
                    stats = Statistics.read(ReadDataStream(io.BytesIO(body)))
                elif opcode == _METADATA_INDEX:
                    found = MetadataIndex.read(ReadDataStream(io.BytesIO(body)))
                    self._metadata_at[found.name] = (found.offset, found.length)
        except (struct.error, ValueError, UnicodeDecodeError, McapError) as exc:
            raise RecordingError(f"corrupt summary ({type(exc).__name__})",
                                 offset=summary_start) from None
        if stats is None:
            raise RecordingError("the summary has no statistics", offset=summary_start)
        self.start = stats.message_start_time  # ns, log time
        self.end = stats.message_end_time
        self.messages = stats.message_count
        self._channels = {cid: (topic, schemas.get(schema_id, ""))
                          for cid, (topic, schema_id) in channels.items()}
        self._chunks.sort()
        self._starts = [c.start for c in self._chunks]
        # the latest end among the chunks up to each: bisect finds the first chunk that
        # may hold a message at or after a time
        self._ends_so_far = list(itertools.accumulate((c.end for c in self._chunks), max))

    def _record(self, offset: int, opcode: int) -> bytes:
        """The body of the record at `offset`, which must be of kind `opcode` (else b"")."""
        self._source.seek(offset)
        head = self._source.read(_RECORD_HEAD.size)
        if len(head) < _RECORD_HEAD.size or head[0] != opcode:
            return b""
        return self._source.read(_RECORD_HEAD.unpack(head)[1])

    @property
    def chunks(self) -> int:
        return len(self._chunks)

    def metadata(self, name: str) -> dict[str, str]:
        """The metadata record `name` ({} if the file has none), read by its index."""
        at = self._metadata_at.get(name)
        if at is None:
            return {}
        body = self._record(at[0], _METADATA)
        try:
            return dict(Metadata.read(ReadDataStream(io.BytesIO(body))).metadata)
        except (struct.error, ValueError, UnicodeDecodeError, McapError):
            raise RecordingError("corrupt metadata record", offset=at[0]) from None

    def chunk_span(self, index: int) -> tuple[int, int]:
        """The log-time span (ns) of the `index`-th chunk, chunks sorted by start."""
        chunk = self._chunks[index]
        return chunk.start, chunk.end

    def chunk_entries(self, index: int) -> ChunkEntries:
        """The messages of the `index`-th chunk (chunks sorted by start), in log-time
        order: one chunk read and decompressed (RecordingError if it is damaged)."""
        chunk = self._chunks[index]
        data, messages = self._messages(chunk, 0)
        return ChunkEntries(self, data, messages, chunk.offset)

    def seek(self, log_time: int) -> Iterator[McapEntry]:
        """The messages logged at or after `log_time` (ns), in log-time order; only the
        chunks the iteration reaches are read (RecordingError where one is damaged)."""
        index = bisect.bisect_left(self._ends_so_far, log_time)
        order = itertools.count()
        pending: list[_Pending] = []  # per open chunk: its next message first
        while True:
            # open every chunk that starts before the next message known (or the next
            # chunk, when none is open): only overlapping chunks are open together
            while index < len(self._chunks) and (
                    not pending or self._starts[index] <= pending[0][0]):
                offset = self._chunks[index].offset
                data, messages = self._messages(self._chunks[index], log_time)
                if messages:
                    heapq.heappush(pending, (messages[0][0], next(order), 0, messages,
                                             data, offset))
                index += 1
            if not pending:
                return
            _, tie, at, messages, data, offset = heapq.heappop(pending)
            yield self._entry(data, messages[at][1], offset)
            if at + 1 < len(messages):
                heapq.heappush(pending, (messages[at + 1][0], tie, at + 1, messages, data,
                                         offset))

    def _entry(self, data: bytes, at: int, offset: int) -> McapEntry:
        channel, _, log_time, publish_time = _MESSAGE_HEAD.unpack_from(data, at + 9)
        length = _RECORD_HEAD.unpack_from(data, at)[1]
        topic, schema = self._channels.get(channel, ("", ""))
        return McapEntry(topic, schema, log_time, publish_time,
                         data[at + 9 + _MESSAGE_HEAD.size:at + 9 + length], offset)

    def _messages(self, chunk: _Chunk, since: int) -> tuple[bytes, list[tuple[int, int]]]:
        """One chunk's records, decompressed, and (log time, position) of each message
        at or after `since`, sorted."""
        offset = chunk.offset
        self._source.seek(offset)
        raw = self._source.read(chunk.length)
        try:
            (opcode, _, _, _, size, crc, name_length, _) = _CHUNK_HEAD.unpack_from(raw)
            name_end = _CHUNK_HEAD.size - 1 + name_length
            compression = raw[_CHUNK_HEAD.size - 1:name_end].decode()
            (records_length,) = struct.unpack_from("<Q", raw, name_end)
            body = raw[name_end + 8:name_end + 8 + records_length]
            data = _decompress(compression, body, size)
        except (struct.error, UnicodeDecodeError, zstandard.ZstdError, RuntimeError,
                ValueError) as exc:
            raise RecordingError(f"corrupt chunk ({type(exc).__name__}: {exc})",
                                 offset=offset) from None
        if opcode != 0x06 or len(data) != size or (crc and zlib.crc32(data) != crc):
            raise RecordingError("corrupt chunk (checksum mismatch)", offset=offset)
        found = []
        at, end = 0, len(data)
        unpack_record, unpack_time = _RECORD_HEAD.unpack_from, struct.Struct("<Q").unpack_from
        while at < end:
            opcode, length = unpack_record(data, at)
            if opcode == _MESSAGE:
                (t,) = unpack_time(data, at + 9 + 6)
                if t >= since:
                    found.append((t, at))
            at += 9 + length
        found.sort()
        return data, found


class ChunkEntries(Sequence[McapEntry]):
    """One chunk's messages in log-time order, each made an entry when asked for."""

    def __init__(self, recording: IndexedRecording, data: bytes,
                 messages: list[tuple[int, int]], offset: int) -> None:
        self._recording, self._data, self._messages = recording, data, messages
        self._offset = offset

    def log_time(self, index: int) -> int:
        """The `index`-th message's log time (ns), without making its entry."""
        return self._messages[index][0]

    def __len__(self) -> int:
        return len(self._messages)

    @overload
    def __getitem__(self, index: int) -> McapEntry: ...

    @overload
    def __getitem__(self, index: slice) -> list[McapEntry]: ...

    def __getitem__(self, index: int | slice) -> McapEntry | list[McapEntry]:
        if isinstance(index, slice):
            return [self[i] for i in range(*index.indices(len(self._messages)))]
        return self._recording._entry(self._data, self._messages[index][1], self._offset)


def _decompress(compression: str, body: bytes, size: int) -> bytes:
    if compression == "zstd":
        return bytes(zstandard.ZstdDecompressor().decompress(body, max_output_size=size))
    if compression == "":
        return body
    raise ValueError(f"compression {compression!r} (MRSS writes zstd)")


class _Chunk(NamedTuple):
    """A chunk as the summary indexes it: its time span (ns), where it is, its length."""

    start: int
    end: int
    offset: int
    length: int


def _records(data: bytes) -> Iterator[tuple[int, bytes]]:
    at = 0
    while at < len(data):
        opcode, length = _RECORD_HEAD.unpack_from(data, at)
        body = data[at + _RECORD_HEAD.size:at + _RECORD_HEAD.size + length]
        if len(body) != length:
            raise ValueError("a summary record is cut short")
        yield opcode, body
        at += _RECORD_HEAD.size + length


def _chunk_index(body: bytes) -> _Chunk:
    """The time span and place of a Chunk Index record's chunk (the rest is not needed)."""
    start, end, offset, length = _CHUNK_SPAN.unpack_from(body)
    return _Chunk(start, end, offset, length)
