"""The `mcap` library's Writer with a lean `add_message`, for the recorder's rate.

The library's `add_message` builds a record object, writes it field by field and updates
the file's statistics and the open chunk's time span and message index on every call;
its chunk's message indexes are then written eight bytes per call. That was most of the
recorder's time per message once decoding was cheap (profiled: `mrss bench record`).

`FastWriter.add_message` writes the record with one `struct.pack` into the open chunk
and keeps only its index entry (log time, offset) in a list of its own; the counts and
time spans follow from those when they are handed to the library's chunk builder and
statistics, just before the library closes a chunk or writes the summary
(`_hand_over`); the message indexes are written with one `struct.pack` each
(`_PackedIndex`). Everything else (chunks, compression, the
summary and its index) is the library's, and the file is the library's byte for byte
(tests/recording/test_mcap_fast.py). It relies on the library's private attributes
(mcap 1.6); where they are not as expected, it is the library's own `add_message`.
"""

from __future__ import annotations

import struct
from typing import IO, Any

from mcap.opcode import Opcode
from mcap.records import MessageIndex
from mcap.writer import Writer

# A Message record: opcode, record length, then channel id, sequence, log and publish time.
_MESSAGE_HEAD = struct.Struct("<BQHIQQ")
_MESSAGE_FIELDS = 2 + 4 + 8 + 8
_INDEX_HEAD = struct.Struct("<BQHI")
_PRIVATE = ("_Writer__statistics", "_Writer__chunk_builder", "_Writer__chunk_size",
            "_Writer__finalize_chunk")


class _PackedIndex(MessageIndex):
    """A chunk's message index for one channel, its entries flat: log time, offset, ..."""

    def write(self, stream: Any) -> None:
        flat = self.records
        stream.write(_INDEX_HEAD.pack(Opcode.MESSAGE_INDEX, 2 + 4 + 8 * len(flat),
                                      self.channel_id, 8 * len(flat)))
        stream.write(struct.pack(f"<{len(flat)}Q", *flat))


class FastWriter(Writer):
    """A chunked `mcap.writer.Writer` whose `add_message` is one pass."""

    def __init__(self, output: str | IO[Any], *args: Any, **kwargs: Any) -> None:
        super().__init__(output, *args, **kwargs)
        builder = getattr(self, "_Writer__chunk_builder", None)
        self._fast = (all(hasattr(self, name) for name in _PRIVATE)
                      and hasattr(builder, "record_writer")
                      and hasattr(builder, "message_indices")
                      and hasattr(getattr(builder, "record_writer", None), "_buffer"))
        self._chunk_size: int = getattr(self, "_Writer__chunk_size", 0)
        # the open chunk's messages, as kept here until `_hand_over`: their counts and
        # time span follow from these
        self._entries: dict[int, list[int]] = {}  # channel -> log time, offset, ...
        self._buffer: Any = None  # the chunk builder's record buffer (replaced per chunk)
        self._refresh()

    @property
    def fast(self) -> bool:
        """Whether the one-pass path is in use (else the library's `add_message`)."""
        return self._fast

    def _refresh(self) -> None:
        if self._fast:
            self._buffer = self._Writer__chunk_builder.record_writer._buffer  # type: ignore[attr-defined]

    def _hand_over(self) -> None:
        """Give the open chunk's messages to the library's chunk builder and statistics."""
        if not self._entries:
            return
        times = [t for flat in self._entries.values() for t in flat[::2]]
        first, last, messages = min(times), max(times), len(times)
        stats = self._Writer__statistics  # type: ignore[attr-defined]
        if stats.message_count == 0 or first < stats.message_start_time:
            stats.message_start_time = first
        stats.message_end_time = max(stats.message_end_time, last)
        stats.message_count += messages
        chunk = self._Writer__chunk_builder  # type: ignore[attr-defined]
        if chunk.num_messages == 0:
            chunk.message_start_time, chunk.message_end_time = first, last
        else:  # handed over before (a channel registered), and not closed since
            chunk.message_start_time = min(chunk.message_start_time, first)
            chunk.message_end_time = max(chunk.message_end_time, last)
        chunk.num_messages += messages
        for channel, flat in self._entries.items():
            stats.channel_message_counts[channel] += len(flat) // 2
            index = chunk.message_indices.get(channel)
            if index is None:
                chunk.message_indices[channel] = _PackedIndex(channel, flat)  # type: ignore[arg-type]
            else:
                index.records += flat
        self._entries = {}

    def add_message(self, channel_id: int, log_time: int, data: bytes, publish_time: int,
                    sequence: int = 0) -> None:
        if not self._fast:
            super().add_message(channel_id, log_time=log_time, data=data,
                                publish_time=publish_time, sequence=sequence)
            return
        buffer = self._buffer
        offset = buffer.tell()
        entries = self._entries.get(channel_id)
        if entries is None:
            entries = self._entries[channel_id] = []
        entries += (log_time, offset)
        buffer.write(_MESSAGE_HEAD.pack(Opcode.MESSAGE, _MESSAGE_FIELDS + len(data),
                                        channel_id, sequence, log_time, publish_time))
        buffer.write(data)
        if offset + 31 + len(data) > self._chunk_size:
            self._hand_over()
            self._Writer__finalize_chunk()  # type: ignore[attr-defined]
            self._refresh()

    # What may close the chunk or write the summary gets the open chunk's messages first.
    def flush(self) -> None:
        if self._fast:
            self._hand_over()
        super().flush()  # type: ignore[no-untyped-call]
        self._refresh()

    def finish(self) -> None:
        if self._fast:
            self._hand_over()
        super().finish()  # type: ignore[no-untyped-call]

    def register_channel(self, topic: str, message_encoding: str, schema_id: int,
                         metadata: dict[str, str] | None = None) -> int:
        if self._fast:
            self._hand_over()
        channel = super().register_channel(topic, message_encoding, schema_id,
                                           metadata or {})
        self._refresh()
        return channel
