"""The run's incarnation key: who may claim which incarnation on the bus.

The root supervisor is the only authority for incarnations. At every start of
`mrss supervise` it writes a fresh random key into the run directory (`incarnation.key`,
readable by its user only), hands the file's path to every component it starts, and
announces each start (`sup.start`) with the new incarnation's credential. A credential
is an HMAC of (src, inc) under the key: a sender carries its own in every envelope
(`cred`), and a receiver that holds the key checks it before it believes that `src`
runs as incarnation `inc` (mrss/bus/incarnations.py). Without the key nobody can mint
one: not a forged heartbeat, not a recording of another run (another key).

On `[nodes]` each node's root has a key of its own; the nodes' bus proxies exchange
them and translate proofs between nodes (mrss/bus/border.py). A key also numbers its run
(`run`, in the same file): at least the root's start time in milliseconds, and above the
run of the key it replaces in a kept run directory, so a node's later run has a higher
number even when its clock went back. Another node knows incarnation i of run r as
`across_runs(r, i)`, so every incarnation of a node's new run ranks above every one of
its last run there (the border translates; the node's own components keep 1, 2, ...).

A credential is not a secret: every message of an incarnation shows it. It proves only
that the supervisor started (src, inc), never anything about a later incarnation.
"""

from __future__ import annotations

import functools
import hashlib
import hmac
import os
import secrets
import time
from collections.abc import Callable
from pathlib import Path

from mrss.errors import BusError

KEY_FILE = "incarnation.key"
KEY_BYTES = 32
CREDENTIAL_BYTES = 16  # HMAC-SHA256 truncated: 128 bits, as HMAC-SHA256-128
RUN_BYTES = 8  # the run's number after the key in the file, big-endian
# Incarnations one run of a node numbers apart on the other nodes (a root's restart
# budget never comes near it); decimal, so that a number shown raw still reads as
# "run ... incarnation ...".
RUN_SPAN = 10**6
MAX_RUN = (2**63 - 1) // RUN_SPAN  # the numbers stay signed 64-bit (SQLite, msgpack)


def across_runs(run: int, inc: int) -> int:
    """The number another node's components know incarnation `inc` (< RUN_SPAN) of a
    node's run `run` by: every incarnation of a later run ranks above every one of an
    earlier run (run 0, a node that numbers no runs: `inc` itself)."""
    return run * RUN_SPAN + inc


def within_run(number: int) -> int:
    """The incarnation within its run of a number `across_runs` made (what the node that
    started it calls it; a number below RUN_SPAN is one already)."""
    return number % RUN_SPAN if number >= RUN_SPAN else number


class IncarnationKey:
    """The key that mints and checks credentials of (src, inc)."""

    __slots__ = ("path", "run", "_key")

    def __init__(self, key: bytes, path: str = "", run: int = 0) -> None:
        if len(key) != KEY_BYTES:
            raise BusError(f"incarnation key {path or '(given)'} is {len(key)} bytes, "
                           f"not {KEY_BYTES}")
        if not 0 <= run <= MAX_RUN:
            raise BusError(f"incarnation key {path or '(given)'}: run {run} is not "
                           f"between 0 and {MAX_RUN}")
        self._key = key
        self.path = path
        self.run = run  # the number of the run this key is for (0: none)

    @classmethod
    def create(cls, run_dir: str | os.PathLike[str], *,
               clock: Callable[[], float] = time.time) -> IncarnationKey:
        """A fresh key for a new run, written to `run_dir/incarnation.key` (mode 0600)
        atomically; its run is the clock in milliseconds, or one above the run of the
        key it replaces if that is higher (a clock that went back)."""
        path = Path(run_dir) / KEY_FILE
        run = max(int(clock() * 1000), _last_run(path) + 1)
        key = secrets.token_bytes(KEY_BYTES)
        partial = path.with_name(f".{KEY_FILE}.{os.getpid()}")
        fd = os.open(partial, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        try:
            os.write(fd, key + run.to_bytes(RUN_BYTES, "big"))
        finally:
            os.close(fd)
        os.replace(partial, path)
        return cls(key, str(path), run)

    def credential(self, src: str, inc: int) -> bytes:
        """The proof that the supervisor started incarnation `inc` of `src`."""
        message = f"{inc}\0{src}".encode()
        return hmac.new(self._key, message, hashlib.sha256).digest()[:CREDENTIAL_BYTES]

    def vouches(self, src: str, inc: int, cred: bytes) -> bool:
        """Whether `cred` proves incarnation `inc` of `src` (constant time)."""
        return len(cred) == CREDENTIAL_BYTES and hmac.compare_digest(
            cred, self.credential(src, inc))

    def export(self) -> str:
        """The key itself, as hex: only for a peer node's border, over the encrypted link
        between nodes (mrss/bus/border.py), never for a log or a local subscriber."""
        return self._key.hex()

    def __eq__(self, other: object) -> bool:
        return isinstance(other, IncarnationKey) and self.run == other.run and \
            hmac.compare_digest(self._key, other._key)

    def __hash__(self) -> int:
        return hash((self._key, self.run))

    def __repr__(self) -> str:
        return f"IncarnationKey({self.path or '<in memory>'})"


def load_key(path: str) -> IncarnationKey:
    """The key in the file at `path` (read once per version of the file); BusError if
    it cannot be read."""
    try:
        st = os.stat(path)
        return _read_key(path, st.st_ino, st.st_mtime_ns)
    except OSError as exc:
        raise BusError(f"cannot read the incarnation key {path}: "
                       f"{exc.strerror or exc}") from None


@functools.lru_cache(maxsize=8)
def _read_key(path: str, inode: int, mtime_ns: int) -> IncarnationKey:
    data = Path(path).read_bytes()
    if len(data) == KEY_BYTES + RUN_BYTES:
        return IncarnationKey(data[:KEY_BYTES], path, int.from_bytes(data[KEY_BYTES:], "big"))
    return IncarnationKey(data, path)  # a key without a run (an older release's)


def _last_run(path: Path) -> int:
    """The run of the key at `path` (0: none, or not readable)."""
    try:
        return load_key(str(path)).run
    except BusError:
        return 0
