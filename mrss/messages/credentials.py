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
them and translate proofs between nodes (mrss/bus/border.py).

A credential is not a secret: every message of an incarnation shows it. It proves only
that the supervisor started (src, inc), never anything about a later incarnation.
"""

from __future__ import annotations

import functools
import hashlib
import hmac
import os
import secrets
from pathlib import Path

from mrss.errors import BusError

KEY_FILE = "incarnation.key"
KEY_BYTES = 32
CREDENTIAL_BYTES = 16  # HMAC-SHA256 truncated: 128 bits, as HMAC-SHA256-128


class IncarnationKey:
    """The key that mints and checks credentials of (src, inc)."""

    __slots__ = ("path", "_key")

    def __init__(self, key: bytes, path: str = "") -> None:
        if len(key) != KEY_BYTES:
            raise BusError(f"incarnation key {path or '(given)'} is {len(key)} bytes, "
                           f"not {KEY_BYTES}")
        self._key = key
        self.path = path

    @classmethod
    def create(cls, run_dir: str | os.PathLike[str]) -> IncarnationKey:
        """A fresh key, written to `run_dir/incarnation.key` (mode 0600) atomically."""
        path = Path(run_dir) / KEY_FILE
        key = secrets.token_bytes(KEY_BYTES)
        partial = path.with_name(f".{KEY_FILE}.{os.getpid()}")
        fd = os.open(partial, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        try:
            os.write(fd, key)
        finally:
            os.close(fd)
        os.replace(partial, path)
        return cls(key, str(path))

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
        return isinstance(other, IncarnationKey) and hmac.compare_digest(self._key,
                                                                         other._key)

    def __hash__(self) -> int:
        return hash(self._key)

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
    return IncarnationKey(Path(path).read_bytes(), path)
