"""The control channel between the root supervisor and one component process.

A Unix SOCK_SEQPACKET socket pair, one end inherited by the child: each message is one
packet `KIND[ TEXT]`, so there is no framing to get wrong and the supervisor sees the
end of the child's process as end-of-file. It does not depend on the bus, so readiness
and hang detection work even when the bus is down.

child -> supervisor: `ready`, `hb` (heartbeat), `fail REASON` (why it is about to exit),
`pong TOKEN`. supervisor -> child: `ping TOKEN`, `crash` (fault injection).
"""

from __future__ import annotations

import socket

READY = "ready"
HEARTBEAT = "hb"
FAIL = "fail"
PING = "ping"
PONG = "pong"
CRASH = "crash"

MAX_PACKET = 4096


def socket_pair() -> tuple[socket.socket, socket.socket]:
    """(supervisor end, child end); the child end is made inheritable by the launcher."""
    return socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)


def encode(kind: str, text: str = "") -> bytes:
    packet = f"{kind} {text}" if text else kind
    return packet.encode("utf-8", "replace")[:MAX_PACKET]


def decode(packet: bytes) -> tuple[str, str]:
    """(kind, text); unknown or garbled packets decode to a kind the reader ignores."""
    kind, _, text = packet.decode("utf-8", "replace").partition(" ")
    return kind, text


def send(sock: socket.socket, kind: str, text: str = "") -> bool:
    """Send one message; False if the other end is gone."""
    try:
        sock.send(encode(kind, text))
        return True
    except OSError:
        return False
