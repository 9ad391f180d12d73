"""The file format of `mrss record` / `mrss replay`: bus messages as raw frames with times.

```
file    := MAGIC header entry*
MAGIC   := b"MRSSREC" + version byte 0x01                       (8 bytes)
header  := block whose body is a msgpack map
           {"created": float, "endpoints": {...}, "prefixes": [str, ...]}
entry   := block whose body is a msgpack array [t, frames, note]
           t: float >= 0 (receive time, Unix seconds), frames: [bin, ...] (the ZeroMQ
           message exactly as received, one or more frames), note: str ("" for a
           well-formed message, else why it did not decode when recorded)
block   := length u32 (big-endian) | crc32(body) u32 (big-endian) | body
```

A block is at most `MAX_BLOCK` bytes. The checksum catches a corrupt block, the length
a truncated one: `RecordingReader` yields every entry before the first such block and
then raises `RecordingError` with that block's offset. A file cut at a block boundary is
simply a shorter recording (a recorder killed between two writes leaves one). An entry
whose block is intact but whose body is not `[t, frames, note]` (only another writer
makes those) is skipped and reported to `on_skip`, and reading goes on.
"""

from __future__ import annotations

import math
import struct
import zlib
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import IO, Any

import msgpack

from mrss.errors import MrssError

MAGIC = b"MRSSREC\x01"
MAX_BLOCK = 64 * 1024 * 1024
_BLOCK_HEAD = struct.Struct("!II")


class RecordingError(MrssError):
    """A recording is not an MRSS recording, or is truncated or corrupt at `offset`."""

    def __init__(self, reason: str, *, offset: int) -> None:
        self.reason = reason
        self.offset = offset
        super().__init__(f"at byte offset {offset}: {reason}")


@dataclass(frozen=True)
class RecordedMessage:
    """One ZeroMQ message seen on the bus: when it arrived, its frames, and any fault.

    `offset` is where its entry starts in the file (0 for one not read from a file).
    """

    t: float
    frames: tuple[bytes, ...]
    note: str = ""
    offset: int = field(default=0, compare=False)

    @property
    def malformed(self) -> bool:
        """Whether the message did not decode as a bus message when it was recorded."""
        return bool(self.note)


class RecordingWriter:
    """Writes a recording to a binary file object: the header at once, then `write` entries.

    Entries are buffered by the file object; `flush` pushes them to the OS, so a recorder
    killed afterwards loses nothing flushed (at worst it leaves a truncated last entry).
    """

    def __init__(self, out: IO[bytes], *, created: float, endpoints: dict[str, str] | None = None,
                 prefixes: Sequence[str] = ("",)) -> None:
        self._out = out
        self._packer = msgpack.Packer(use_bin_type=True)
        self.count = 0
        self.malformed = 0
        out.write(MAGIC)
        self._block({"created": float(created), "endpoints": dict(endpoints or {}),
                     "prefixes": list(prefixes)})

    def write(self, message: RecordedMessage) -> None:
        """Append one entry."""
        if not message.frames:
            raise ValueError("a recorded message has at least one frame")
        if not math.isfinite(message.t) or message.t < 0:
            raise ValueError(f"receive time {message.t!r} is not finite and >= 0")
        self._block([float(message.t), [bytes(f) for f in message.frames], message.note])
        self.count += 1
        self.malformed += message.malformed

    def _block(self, value: Any) -> None:
        body = self._packer.pack(value)
        if len(body) > MAX_BLOCK:
            raise ValueError(f"entry of {len(body)} bytes exceeds {MAX_BLOCK}")
        self._out.write(_BLOCK_HEAD.pack(len(body), zlib.crc32(body)) + body)

    def flush(self) -> None:
        self._out.flush()


class RecordingReader:
    """Reads a recording from a binary file object: `header`, then iterate the entries.

    The constructor reads the magic and the header (RecordingError at offset 0 or 8 if
    either is wrong). Iteration yields `RecordedMessage`s in file order and raises
    RecordingError at the first truncated or corrupt block; undecodable entries go to
    `on_skip(offset, reason)` and are not yielded.
    """

    def __init__(self, source: IO[bytes],
                 on_skip: Callable[[int, str], None] | None = None) -> None:
        self._in = source
        self._on_skip = on_skip
        magic = source.read(len(MAGIC))
        if magic != MAGIC:
            if magic[:7] == MAGIC[:7] and len(magic) == len(MAGIC):
                raise RecordingError(f"recording format version {magic[7]} is not supported",
                                     offset=0)
            raise RecordingError("not an MRSS recording (bad magic)", offset=0)
        self._offset = len(MAGIC)
        body = self._next_block()
        if body is None:
            raise RecordingError("the header is missing", offset=len(MAGIC))
        header = _unpack(body)
        if not isinstance(header, dict) or not isinstance(header.get("created"), float):
            raise RecordingError("the header is not a map with a creation time",
                                 offset=len(MAGIC))
        self.header: dict[str, Any] = header

    @property
    def offset(self) -> int:
        """Where the next block starts: after a full read, the length of the valid part."""
        return self._offset

    def __iter__(self) -> Iterator[RecordedMessage]:
        while True:
            start = self._offset
            body = self._next_block()
            if body is None:
                return
            message, reason = _entry(_unpack(body), start)
            if message is not None:
                yield message
            elif self._on_skip is not None:
                self._on_skip(start, reason)

    def _next_block(self) -> bytes | None:
        """The next block's body; None at a clean end of file; RecordingError if damaged."""
        start = self._offset
        head = self._in.read(_BLOCK_HEAD.size)
        if not head:
            return None
        if len(head) < _BLOCK_HEAD.size:
            raise RecordingError(f"truncated entry: {len(head)} of {_BLOCK_HEAD.size} header "
                                 f"bytes", offset=start)
        length, crc = _BLOCK_HEAD.unpack(head)
        if length > MAX_BLOCK:
            raise RecordingError(f"corrupt entry: length {length} exceeds {MAX_BLOCK}",
                                 offset=start)
        body = self._in.read(length)
        if len(body) < length:
            raise RecordingError(f"truncated entry: {len(body)} of {length} bytes",
                                 offset=start)
        if zlib.crc32(body) != crc:
            raise RecordingError("corrupt entry: checksum mismatch", offset=start)
        self._offset = start + _BLOCK_HEAD.size + length
        return body


_UNDECODABLE = object()


def _unpack(body: bytes) -> Any:
    try:
        return msgpack.unpackb(body, raw=False, strict_map_key=True)
    except Exception:  # msgpack raises many types for garbage; the caller reports it
        return _UNDECODABLE


def _entry(value: Any, offset: int) -> tuple[RecordedMessage | None, str]:
    """The message an entry body holds, or None and why it is not one."""
    if value is _UNDECODABLE:
        return None, "entry is not msgpack"
    if not isinstance(value, list) or len(value) != 3:
        return None, "entry is not [time, frames, note]"
    t, frames, note = value
    if not isinstance(t, float) or not math.isfinite(t) or t < 0:
        return None, "entry time is not a finite float >= 0"
    if (not isinstance(frames, list) or not frames
            or not all(isinstance(f, bytes) for f in frames)):
        return None, "entry frames are not a non-empty list of bytes"
    if not isinstance(note, str):
        return None, "entry note is not a string"
    return RecordedMessage(t, tuple(frames), note, offset), ""
