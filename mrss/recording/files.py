"""Which reader a recording file needs: MCAP (what `mrss record` writes) or the older
MRSS block format (mrss/recording/format.py, read only)."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import IO

from mrss.recording.format import MAGIC as LEGACY_MAGIC
from mrss.recording.format import RecordedMessage, RecordingError, RecordingReader
from mrss.recording.mcap_reader import MAGIC, McapRecording


def is_mcap(source: IO[bytes]) -> bool:
    """Whether a seekable file starts with MCAP's magic (its position is kept)."""
    start = source.tell()
    magic = source.read(len(MAGIC))
    source.seek(start)
    return magic == MAGIC


def recorded_messages(source: IO[bytes],
                      on_skip: Callable[[int, str], None] | None = None
                      ) -> Iterator[RecordedMessage]:
    """The bus messages of a recording of either format, in file order.

    The file's start is checked at once (RecordingError at offset 0: neither format);
    damage further on raises RecordingError when reading reaches it.
    """
    if is_mcap(source):
        return McapRecording(source).recorded()
    start = source.tell()
    head = source.read(len(LEGACY_MAGIC))
    source.seek(start)
    if head[:7] != LEGACY_MAGIC[:7]:
        raise RecordingError("neither an MCAP file nor an MRSS recording (bad magic)",
                             offset=0)
    return iter(RecordingReader(source, on_skip=on_skip))
