"""The `mcap` library's Writer with a one-pass `add_message`, for the recorder's rate.

The library's `add_message` builds a record object and writes it field by field through
a dozen small calls; with JSON encoding and validation, that was 40 % of the recorder's
time per message (profiled: `mrss bench record`). `FastWriter.add_message` does the same
bookkeeping (statistics, the open chunk's time span and message index) and writes the
record with one `struct.pack`. It relies on the library's private attributes (mcap
1.6); where they are not as expected, it is the library's own `add_message`.
Everything else (chunks, compression, the summary and its index) is the library's.
"""

from __future__ import annotations

import struct
from typing import Any

from mcap.opcode import Opcode
from mcap.records import MessageIndex
from mcap.writer import Writer

# A Message record: opcode, record length, then channel id, sequence, log and publish time.
_MESSAGE_HEAD = struct.Struct("<BQHIQQ")
_MESSAGE_FIELDS = 2 + 4 + 8 + 8
_PRIVATE = ("_Writer__statistics", "_Writer__chunk_builder", "_Writer__chunk_size")


class FastWriter(Writer):
    """A chunked `mcap.writer.Writer` whose `add_message` is one pass."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        builder = getattr(self, "_Writer__chunk_builder", None)
        self._fast = (all(hasattr(self, name) for name in _PRIVATE)
                      and hasattr(builder, "record_writer")
                      and hasattr(builder, "message_indices")
                      and hasattr(self, "_Writer__finalize_chunk"))

    @property
    def fast(self) -> bool:
        """Whether the one-pass path is in use (else the library's `add_message`)."""
        return self._fast

    def add_message(self, channel_id: int, log_time: int, data: bytes, publish_time: int,
                    sequence: int = 0) -> None:
        if not self._fast:
            super().add_message(channel_id, log_time=log_time, data=data,
                                publish_time=publish_time, sequence=sequence)
            return
        stats = self._Writer__statistics  # type: ignore[attr-defined]
        if stats.message_count == 0 or log_time < stats.message_start_time:
            stats.message_start_time = log_time
        if log_time > stats.message_end_time:
            stats.message_end_time = log_time
        stats.channel_message_counts[channel_id] += 1
        stats.message_count += 1
        chunk = self._Writer__chunk_builder  # type: ignore[attr-defined]
        if chunk.num_messages == 0 or log_time < chunk.message_start_time:
            chunk.message_start_time = log_time
        if log_time > chunk.message_end_time:
            chunk.message_end_time = log_time
        index = chunk.message_indices.get(channel_id)
        if index is None:
            index = chunk.message_indices[channel_id] = MessageIndex(channel_id=channel_id,
                                                                     records=[])
        records = chunk.record_writer
        index.records.append((log_time, records.count))
        chunk.num_messages += 1
        records.write(_MESSAGE_HEAD.pack(Opcode.MESSAGE, _MESSAGE_FIELDS + len(data),
                                         channel_id, sequence, log_time, publish_time) + data)
        if records.count > self._Writer__chunk_size:  # type: ignore[attr-defined]
            self._Writer__finalize_chunk()  # type: ignore[attr-defined]
