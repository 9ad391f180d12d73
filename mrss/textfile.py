"""Text files: read as UTF-8 with an error that says where it is not, written whole.

`read_text(path)` is `Path.read_text(encoding="utf-8")` whose UnicodeDecodeError becomes a
`NotUtf8Error` naming the file, the line and the byte offset of the first bad byte, so
every command reports a stray Latin-1 byte the same way instead of with a traceback; a
file larger than `MAX_BYTES` (16 MiB, or an endless one such as /dev/zero) is an OSError.

`write_whole(path, text)` writes a file another process reads (an address, a URL): the
reader sees the old text or the new, never a partial one.
"""

from __future__ import annotations

import errno
import os
import threading
from pathlib import Path

from mrss.errors import MrssError


class NotUtf8Error(MrssError):
    """A file that should be UTF-8 text is not: `line` (1-based) and byte `offset` of the
    first byte that does not decode."""

    def __init__(self, file: str, line: int, col: int, offset: int, byte: int,
                 source_line: str = "") -> None:
        self.file = file
        self.source_line = source_line  # the line, bad bytes shown as U+FFFD
        self.line = line
        self.col = col
        self.offset = offset
        self.reason = (f"not UTF-8 text: byte 0x{byte:02x} at byte offset {offset} "
                       f"(save the file as UTF-8)")
        super().__init__(f"{file}:{line}:{col}: {self.reason}")


def decode(data: bytes, file: str) -> str:
    """`data` decoded as UTF-8 (NotUtf8Error naming `file` if it is not)."""
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        start = exc.start
        line_start = data.rfind(b"\n", 0, start) + 1
        line = data.count(b"\n", 0, start) + 1
        col = len(data[line_start:start].decode("utf-8", errors="replace")) + 1
        end = data.find(b"\n", start)
        text = data[line_start:end if end >= 0 else len(data)]
        shown = text.decode("utf-8", errors="replace").rstrip("\r")[:200]
        raise NotUtf8Error(file, line, col, start, data[start], shown) from None


MAX_BYTES = 16 * 1024 * 1024  # a source or configuration file larger than this is refused


def read_text(path: Path) -> str:
    """The file's text (OSError if it cannot be read or is larger than MAX_BYTES, as
    /dev/zero would be; NotUtf8Error if it is not UTF-8)."""
    with path.open("rb") as f:
        data = f.read(MAX_BYTES + 1)
    if len(data) > MAX_BYTES:
        raise OSError(errno.EFBIG, f"larger than {MAX_BYTES // (1024 * 1024)} MiB", str(path))
    return decode(data, str(path))


def write_whole(path: Path, text: str) -> None:
    """Write `text` to `path` as one step for any reader: into a partial file of this
    process and thread beside it, then renamed over `path` (a reader polling for the
    file never finds it empty or half written)."""
    partial = path.with_name(f".{path.name}.{os.getpid()}.{threading.get_ident()}.partial")
    try:
        partial.write_text(text, encoding="utf-8")
        os.replace(partial, path)
    except BaseException:
        partial.unlink(missing_ok=True)
        raise
