"""Seeking in a finished MCAP recording by time, through its summary's chunk index.

The `mcap` library's indexed reader puts every chunk after the time into a heap, then
every message of the first one, before it gives one message: on a 1 GB recording
(16,000 chunks) that was a 478 ms p99 seek on a loaded machine (`mrss bench record`).
`IndexedRecording` keeps the chunk index sorted by start time with the running maximum
of end times, so the chunk that holds the first message at or after a time is found by
bisection; it reads and decompresses that one chunk, and the next ones only as the
reader goes on (or where chunks overlap in time, which a clock stepping back makes
possible: they are merged, so messages come in log-time order all the same).
"""

from __future__ import annotations

import bisect
import heapq
import itertools
import struct
import zlib
from collections.abc import Iterator
from typing import IO

import zstandard
from mcap.exceptions import McapError
from mcap.reader import SeekingReader
from mcap.records import ChunkIndex

from mrss.recording.format import RecordingError
from mrss.recording.mcap_reader import MAGIC, McapEntry
from mrss.recording.mcap_writer import PROFILE

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
        source.seek(0)
        if source.read(len(MAGIC)) != MAGIC:
            raise RecordingError("not an MCAP file (bad magic)", offset=0)
        source.seek(0)
        try:
            reader = SeekingReader(source, validate_crcs=False)
            header = reader.get_header()
            summary = reader.get_summary()
        except (McapError, struct.error, ValueError, EOFError) as exc:
            raise RecordingError(f"no readable summary ({type(exc).__name__}): the "
                                 "recorder did not finish; read it in order",
                                 offset=source.seek(0, 2)) from None
        if header.profile != PROFILE:
            raise RecordingError(f"an MCAP file, but not an MRSS recording (profile "
                                 f"{header.profile!r})", offset=len(MAGIC))
        if summary is None or summary.statistics is None:
            raise RecordingError("the file has no summary (the recorder did not finish): "
                                 "read it in order", offset=source.seek(0, 2))
        self.start = summary.statistics.message_start_time  # ns, log time
        self.end = summary.statistics.message_end_time
        self.messages = summary.statistics.message_count
        self._channels = {
            cid: (ch.topic, summary.schemas[ch.schema_id].name
                  if ch.schema_id in summary.schemas else "")
            for cid, ch in summary.channels.items()}
        self._chunks: list[ChunkIndex] = sorted(summary.chunk_indexes,
                                                key=lambda c: c.message_start_time)
        self._starts = [c.message_start_time for c in self._chunks]
        # the latest end among the chunks up to each: bisect finds the first chunk that
        # may hold a message at or after a time
        self._ends_so_far = list(itertools.accumulate(
            (c.message_end_time for c in self._chunks), max))

    @property
    def chunks(self) -> int:
        return len(self._chunks)

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
                offset = self._chunks[index].chunk_start_offset
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

    def _messages(self, chunk: ChunkIndex, since: int) -> tuple[bytes, list[tuple[int, int]]]:
        """One chunk's records, decompressed, and (log time, position) of each message
        at or after `since`, sorted."""
        offset = chunk.chunk_start_offset
        self._source.seek(offset)
        raw = self._source.read(chunk.chunk_length)
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


def _decompress(compression: str, body: bytes, size: int) -> bytes:
    if compression == "zstd":
        return bytes(zstandard.ZstdDecompressor().decompress(body, max_output_size=size))
    if compression == "":
        return body
    raise ValueError(f"compression {compression!r} (MRSS writes zstd)")
