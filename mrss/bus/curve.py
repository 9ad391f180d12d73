"""CurveZMQ keys of the nodes, and the gate (a ZAP handler) that admits only known peers.

Each node has a keypair in the project's keys folder (`[bus] keys_dir`, default `keys/`),
made by `mrss keys PROJECT --node NAME`: `NAME.secret` (owner-only, 0600; it stays on
that node) and `NAME.public` (copied to every other node). A secret key readable by
group or others, or a public key writable by them, is refused with the chmod that
fixes it: a key anyone may read authenticates anyone.

`ZapGate` answers ZeroMQ's authentication requests (ZAP, RFC 27) for the sockets of one
context: a CURVE client whose public key is a known node's is admitted as that node (the
node name becomes the messages' `User-Id`); anyone else is refused and logged with the
address it came from and the key it offered.
"""

from __future__ import annotations

import logging
import os
import stat
from dataclasses import dataclass
from pathlib import Path

import zmq
from zmq.utils import z85

from mrss.errors import ConfigError

log = logging.getLogger("mrss.bus.curve")

ZAP_ENDPOINT = "inproc://zeromq.zap.01"
DOMAIN = b"mrss"
PUBLIC_SUFFIX = ".public"
SECRET_SUFFIX = ".secret"


@dataclass(frozen=True)
class NodeKeys:
    """A node's CurveZMQ keypair, Z85-encoded (40 characters each)."""

    node: str
    public: bytes
    secret: bytes


def generate(directory: Path, node: str, *, force: bool = False) -> tuple[Path, Path]:
    """Write a new keypair for `node`: (public file, secret file). The secret is created
    owner-only; existing keys are kept unless `force` (ConfigError names them)."""
    directory.mkdir(parents=True, exist_ok=True)
    public_path, secret_path = paths(directory, node)
    if not force and (public_path.exists() or secret_path.exists()):
        raise ConfigError(f"keys of node {node!r} exist already ({secret_path}); "
                          "--force replaces them", key="node")
    public, secret = zmq.curve_keypair()
    secret_path.unlink(missing_ok=True)
    fd = os.open(secret_path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    with os.fdopen(fd, "w") as out:
        out.write(secret.decode() + "\n")
    public_path.write_text(public.decode() + "\n")
    public_path.chmod(0o644)
    return public_path, secret_path


def paths(directory: Path, node: str) -> tuple[Path, Path]:
    return directory / f"{node}{PUBLIC_SUFFIX}", directory / f"{node}{SECRET_SUFFIX}"


def load_keys(directory: Path, node: str) -> NodeKeys:
    """This node's keypair; ConfigError for a missing, malformed or exposed file."""
    public_path, secret_path = paths(directory, node)
    return NodeKeys(node, load_public(directory, node), _read_key(secret_path, secret=True,
                                                                  node=node))


def load_public(directory: Path, node: str) -> bytes:
    """A node's public key (ConfigError if missing, malformed or writable by others)."""
    return _read_key(paths(directory, node)[0], secret=False, node=node)


def permission_problem(path: Path, *, secret: bool) -> str:
    """Why the key file at `path` may not be used ("" if it may)."""
    mode = stat.S_IMODE(path.stat().st_mode)
    if secret and mode & 0o077:
        return (f"{path} may be read by others (mode {mode:04o}); a secret key must be "
                f"owner-only: chmod 600 {path}")
    if not secret and mode & 0o022:
        return (f"{path} may be changed by others (mode {mode:04o}): chmod 644 {path}")
    return ""


def _read_key(path: Path, *, secret: bool, node: str) -> bytes:
    what = "secret" if secret else "public"
    if not path.is_file():
        raise ConfigError(f"no {what} key of node {node!r} at {path}; make one with "
                          f"`mrss keys PROJECT --node {node}`"
                          + ("" if secret else " on that node and copy its .public file here"),
                          key="keys_dir")
    problem = permission_problem(path, secret=secret)
    if problem:
        raise ConfigError(problem, key="keys_dir")
    text = path.read_text(encoding="ascii", errors="replace").strip()
    try:
        if len(text) != 40 or len(z85.decode(text)) != 32:
            raise ValueError(text)
    except ValueError:
        raise ConfigError(f"{path} is not a CurveZMQ {what} key (40 Z85 characters)",
                          key="keys_dir") from None
    return text.encode("ascii")


class ZapGate:
    """The ZAP handler of one context: known node keys in, everything else out (logged).

    Not a thread: its socket joins the owner's poll loop (`socket`, then `handle()`
    when it is readable), so there is nothing to lock.
    """

    def __init__(self, ctx: zmq.Context[zmq.Socket[bytes]], known: dict[bytes, str]) -> None:
        self.known = dict(known)  # Z85 public key -> node name
        self.refused = 0
        self._logged: dict[tuple[str, bytes], int] = {}
        self.socket = ctx.socket(zmq.REP)
        self.socket.setsockopt(zmq.LINGER, 0)
        self.socket.bind(ZAP_ENDPOINT)

    def handle(self) -> None:
        """Answer one pending ZAP request."""
        frames = self.socket.recv_multipart()
        if len(frames) < 6:
            log.warning("malformed ZAP request of %d frames ignored", len(frames))
            self.socket.send_multipart([b"1.0", b"", b"500", b"malformed", b"", b""])
            return
        version, request_id, _domain, address, _identity, mechanism = frames[:6]
        credentials = frames[6:]
        status, text, user = b"400", b"unknown key", b""
        if mechanism == b"CURVE" and len(credentials) == 1 and len(credentials[0]) == 32:
            key = z85.encode(credentials[0])
            node = self.known.get(key)
            if node is not None:
                status, text, user = b"200", b"OK", node.encode()
            else:
                self._refuse(address.decode(errors="replace"), key)
        elif mechanism == b"NULL":  # the proxy's local (ipc, loopback) sockets
            status, text = b"200", b"OK"
        else:
            self._refuse(address.decode(errors="replace"), mechanism)
        self.socket.send_multipart([version, request_id, status, text, user, b""])

    def _refuse(self, address: str, key: bytes) -> None:
        self.refused += 1
        seen = self._logged.get((address, key), 0)
        if len(self._logged) >= 1024:
            self._logged.clear()
        self._logged[(address, key)] = seen + 1
        if seen == 0 or (seen + 1) % 100 == 0:
            log.warning("refused a peer at %s: its key %s is not a node of this project "
                        "(%d attempt(s))", address or "?", key.decode(errors="replace"),
                        seen + 1)

    def close(self) -> None:
        self.socket.close(0)
