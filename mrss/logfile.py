"""The run's log file on disk: bounded by size, written by many processes, read back whole.

`[logs]` of project.toml (`LOG_OPTIONS`): when `mrss.log` reaches `max_mb` it is renamed
`mrss.log.1` (the previous `.1` becomes `.2`, and so on; the one past `keep` is deleted)
and a new `mrss.log` begins. So a run's log takes at most about `(keep + 1) x max_mb`.

Every process of a run appends to the file itself (`LogFile`: O_APPEND, one `write` a
record), so rotation must not lose another process's lines:

- before each write a process compares the file it holds with the one the name now
  points to (inode), and reopens the name when they differ: after a rotation by any
  process, its next line goes to the new file;
- a line written in the instant between that look and a rotation lands at the end of
  `mrss.log.1`: kept, not lost (readers take every file, `history_files`);
- a writer that finds the file full rotates it before writing, under an exclusive
  `flock` of the log's lock file (`mrss.log.lock`), and looks again at the size under
  the lock, so two processes that both see a full file rotate once. It does not wait for
  the lock (the holder is rotating) unless the file has grown to `OVERFULL` times
  `max_bytes` meanwhile (the holder is slow, the machine busy): so no file passes twice
  `max_bytes` by more than the records in flight. Writing itself takes no lock; only a
  process frozen (SIGSTOP) in the middle of a rotation, while the file doubles, holds up
  the others until it runs again.

The root supervisor hands its settings to every process of its tree in `$MRSS_LOG_ROTATION`
(`Rotation.to_env`); a process without it uses the declared defaults.
"""

from __future__ import annotations

import fcntl
import os
import re
import threading
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mrss.errors import ConfigError
from mrss.options import Check, Option

MB = 2**20
ENV = "MRSS_LOG_ROTATION"  # "<max bytes>:<keep>", set by the root for its tree
LOCK_SUFFIX = ".lock"
# A file this many times `max_bytes` is not written on while another process rotates it:
# the writer waits for that rotation (it is being slow: the machine is busy).
OVERFULL = 2

#: The keys of `[logs]` (read by `Rotation.of_table`; `mrss check` validates them).
LOG_OPTIONS: tuple[Option, ...] = (
    Option("max_mb", float, 20.0, "the run's log file (mrss.log) is rotated when it reaches "
           "this size, in MB", Check.POSITIVE),
    Option("keep", int, 5, "rotated log files kept (mrss.log.1, the newest, .. "
           "mrss.log.<keep>); older ones are deleted", Check.POSITIVE),
)
_MAX_MB, _KEEP = LOG_OPTIONS


@dataclass(frozen=True)
class Rotation:
    """When the log is rotated (`max_bytes`) and how many rotated files are kept."""

    max_bytes: int
    keep: int

    @classmethod
    def of_table(cls, table: Mapping[str, Any], *, file: str = "") -> Rotation:
        """The `[logs]` table (its declared defaults for what it lacks)."""
        try:
            max_mb = _MAX_MB.read(table, section="logs")
            keep = _KEEP.read(table, section="logs")
        except ConfigError as exc:
            raise ConfigError(exc.reason, file=file, key=exc.key) from None
        return cls(max(1, int(max_mb * MB)), int(keep))

    def to_env(self) -> str:
        return f"{self.max_bytes}:{self.keep}"

    @classmethod
    def from_env(cls, environ: Mapping[str, str] = os.environ) -> Rotation:
        """The root's settings from `$MRSS_LOG_ROTATION`, else the declared defaults."""
        found = re.fullmatch(r"(\d+):(\d+)", environ.get(ENV, "").strip())
        if found and int(found[1]) > 0 and int(found[2]) > 0:
            return cls(int(found[1]), int(found[2]))
        return cls.of_table({})


class LogFile:
    """Appends to a log file shared by many processes, rotating it by `rotation`."""

    def __init__(self, path: str | os.PathLike[str], rotation: Rotation) -> None:
        self.path = Path(path)
        self.rotation = rotation
        self.rotations = 0  # how many rotations this writer did
        self._fd = self._open()
        self._lock_fd = -1

    def _open(self) -> int:
        return os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT | os.O_CLOEXEC, 0o644)

    def write(self, data: bytes) -> None:
        """Append `data` in one `write` (a regular file takes it whole; a full disk
        raises OSError) to the file the name points to now, rotated first if it is full."""
        if self._fd < 0:
            raise ValueError(f"{self.path}: closed")
        self._follow()
        size = os.fstat(self._fd).st_size
        if size >= self.rotation.max_bytes:
            self._rotate(wait=size >= OVERFULL * self.rotation.max_bytes)
            self._follow()
        while data:
            data = data[os.write(self._fd, data):]

    def _follow(self) -> None:
        """Reopen the name if another process rotated the file we hold."""
        try:
            now = os.stat(self.path)
        except FileNotFoundError:  # between a rotation's rename and its new file
            now = None
        held = os.fstat(self._fd)
        if now is None or (now.st_ino, now.st_dev) != (held.st_ino, held.st_dev):
            fd = self._open()
            os.close(self._fd)
            self._fd = fd

    def _rotate(self, wait: bool) -> None:
        """Rotate the file unless another process is at it; with `wait`, wait for that
        one instead of writing on into a file already `OVERFULL` times too large."""
        if self._lock_fd < 0:
            self._lock_fd = os.open(f"{self.path}{LOCK_SUFFIX}",
                                    os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o644)
        try:
            fcntl.flock(self._lock_fd, fcntl.LOCK_EX | (0 if wait else fcntl.LOCK_NB))
        except BlockingIOError:
            return  # another process is rotating it
        try:
            try:
                if os.stat(self.path).st_size < self.rotation.max_bytes:
                    return  # rotated meanwhile by another process
            except FileNotFoundError:
                return
            name = str(self.path)
            for n in sorted(_rotated(self.path), reverse=True):  # those there are, only:
                try:  # the others write on meanwhile, into the file about to be .1
                    if n >= self.rotation.keep:
                        os.unlink(f"{name}.{n}")
                    else:
                        os.replace(f"{name}.{n}", f"{name}.{n + 1}")
                except FileNotFoundError:
                    pass
            os.replace(name, f"{name}.1")
            self.rotations += 1
            fd = self._open()
            os.close(self._fd)
            self._fd = fd
        finally:
            fcntl.flock(self._lock_fd, fcntl.LOCK_UN)

    def close(self) -> None:
        for fd in (self._fd, self._lock_fd):
            if fd >= 0:
                os.close(fd)
        self._fd = self._lock_fd = -1


class LogPump:
    """Copies what a pipe carries (a process tree's stdout and stderr) into a `LogFile`,
    whole lines at a time, on a thread of its own, until the pipe's writers are gone."""

    CHUNK = 65536  # read at once
    PIECE = 4096  # written at once (whole lines, or one longer line): a file passes
    # max_bytes by no more

    def __init__(self, read_fd: int, file: LogFile) -> None:
        self.file = file
        self._fd = read_fd
        self._thread = threading.Thread(target=self._run, name="mrss-log-pump", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        pending = b""
        try:
            while chunk := os.read(self._fd, self.CHUNK):
                whole, newline, pending = (pending + chunk).rpartition(b"\n")
                if newline:
                    self._write_lines((whole + newline).splitlines(keepends=True))
            if pending:
                self._write(pending + b"\n")
        finally:
            os.close(self._fd)

    def _write_lines(self, lines: list[bytes]) -> None:
        piece = b""
        for line in lines:
            if piece and len(piece) + len(line) > self.PIECE:
                self._write(piece)
                piece = b""
            piece += line
        if piece:
            self._write(piece)

    def _write(self, data: bytes) -> None:
        try:
            self.file.write(data)
        except OSError:
            pass  # a full disk: the lines are lost, as a direct write's would be

    def join(self, timeout: float | None = None) -> bool:
        """Wait until the pipe is drained (every writer closed it); whether it is."""
        self._thread.join(timeout)
        return not self._thread.is_alive()


def _rotated(path: Path) -> dict[int, Path]:
    """The rotated files of the log at `path` that exist, by number."""
    found: dict[int, Path] = {}
    try:
        entries = list(path.parent.iterdir())
    except OSError:
        return found
    for entry in entries:
        suffix = entry.name.removeprefix(path.name + ".")
        if entry.name != suffix and suffix.isdigit():
            found[int(suffix)] = entry
    return found


def history_files(path: str | os.PathLike[str]) -> list[Path]:
    """The log's files that exist, oldest first: `mrss.log.<n>` .. `mrss.log.1`, `mrss.log`."""
    path = Path(path)
    rotated = _rotated(path)
    files = [rotated[n] for n in sorted(rotated, reverse=True)]
    return files + [path] if path.exists() else files


def read_history(path: str | os.PathLike[str]) -> str:
    """The whole log as text, its rotated files first (OSError if none can be read: the
    error of the current file when it is missing)."""
    files = history_files(path)
    if not files:
        Path(path).read_bytes()  # raises the reason (FileNotFoundError, ...)
    parts = []
    for file in files:
        try:
            parts.append(file.read_text(encoding="utf-8", errors="replace"))
        except FileNotFoundError:  # rotated away while we read: older than what we have
            continue
    return "".join(parts)


def read_tail(path: str | os.PathLike[str], size: int) -> str:
    """The last `size` bytes (about) of the log, across a rotation; "" if unreadable."""
    parts: list[bytes] = []
    left = size
    for file in reversed(history_files(path)):
        try:
            with file.open("rb") as f:
                end = f.seek(0, os.SEEK_END)
                f.seek(max(0, end - left))
                data = f.read()
        except OSError:
            continue
        parts.insert(0, data)
        left -= len(data)
        if left <= 0:
            break
    return b"".join(parts).decode("utf-8", "replace")


def total_size(path: str | os.PathLike[str]) -> int:
    """Bytes of the log and its rotated files."""
    total = 0
    for file in history_files(path):
        try:
            total += file.stat().st_size
        except OSError:
            continue
    return total
