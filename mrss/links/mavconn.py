"""Open a pymavlink connection that speaks MAVLink 2 with the ardupilotmega dialect.

pymavlink picks its wire version from a process-wide environment variable at import
time; we set the version per connection instead, so a link and a simulator in one
process (tests) and a ground station on the other side (MAVProxy) all agree.

With a signing key (`mrss.links.mavlink_signing`) every message sent is signed and only
messages signed with the key are received; over UDP a sender becomes a peer (one we send
to) only with a datagram that held an accepted message.
"""

from __future__ import annotations

import errno
import ipaddress
import logging
import select
import threading
import time
from collections import deque
from typing import Any

from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from mrss.links.mavlink_signing import Signing, SigningParser

MAV = mavlink2  # message classes and constants of the dialect we speak


class MavConnection:
    """A pymavlink connection with a lock around sends so several threads may send."""

    def __init__(self, url: str, *, source_system: int, source_component: int,
                 udp_timeout: float = 0.0, signing_key: bytes | None = None,
                 link_id: int = 0, name: str = "", log: logging.Logger | None = None) -> None:
        self.url = url
        self.conn: Any = mavutil.mavlink_connection(
            url, source_system=source_system, source_component=source_component,
            udp_timeout=udp_timeout,
        )
        # Replace the version-1 encoder/decoder pymavlink may have chosen.
        mav = SigningParser(self.conn, srcSystem=source_system, srcComponent=source_component)
        mav.robust_parsing = True
        self.signing: Signing | None = None
        if signing_key is not None:
            self.signing = Signing(signing_key, link_id=link_id, name=name or url, log=log)
            self.signing.attach(mav)
        self.conn.mav = mav
        self.conn.WIRE_PROTOCOL_VERSION = "2.0"
        self.conn.first_byte = False
        self._send_lock = threading.Lock()
        self._datagrams = isinstance(self.conn, mavutil.mavudp)
        if self._datagrams:
            _bind_loopback_sender(self.conn)
        self._queued: deque[Any] = deque()

    @property
    def datagrams(self) -> bool:
        """Whether this is a UDP connection (its `socket` may be watched by a selector)."""
        return self._datagrams

    @property
    def socket(self) -> Any:
        """The UDP socket (only for `datagrams`)."""
        return self.conn.port

    def pending(self) -> bool:
        """Whether a message is queued or the socket is readable right now (UDP)."""
        if self._queued:
            return True
        readable, _, _ = select.select([self.conn.port], [], [], 0)
        return bool(readable)

    def send(self, message: Any) -> None:
        """Encode and send one MAVLink message (thread-safe)."""
        with self._send_lock:
            self.conn.mav.send(message)

    def recv(self, timeout: float) -> Any | None:
        """The next decoded message, or None after `timeout` seconds without one."""
        if self._datagrams:
            return self._recv_datagram(timeout)
        if timeout <= 0:
            msg = self.conn.recv_match(blocking=False)
        else:
            msg = self.conn.recv_match(blocking=True, timeout=timeout)
        if msg is None or not self._accepts(msg, self.conn.mav):
            return None
        return msg

    def refused(self) -> dict[str, int]:
        """Messages refused under signing, by reason ({} without a key)."""
        if self.signing is None:
            return {}
        return self.signing.totals()

    def _accepts(self, msg: Any, parser: Any) -> bool:
        if self.signing is not None and not self.signing.accepts(msg, parser):
            return False
        return bool(msg.get_type() != "BAD_DATA")

    def wait_readable(self, timeout: float) -> None:
        """Block until a message may be ready, or `timeout` seconds have passed."""
        if self._queued:
            return
        if self._datagrams:
            select.select([self.conn.port], [], [], timeout)
        else:
            self.conn.select(timeout)

    def _recv_datagram(self, timeout: float) -> Any | None:
        """UDP: decode each datagram on its own, so junk in one cannot swallow the next.

        pymavlink's stream parser would take a stray 0xFD byte as the start of a packet
        and read the following datagrams into it; a datagram only ever holds whole
        packets, so a fresh parser per datagram drops such junk with its datagram.
        """
        if self._queued:
            return self._queued.popleft()
        if timeout > 0:  # the socket does not block: without a wait, read at once
            readable, _, _ = select.select([self.conn.port], [], [], timeout)
            if not readable:
                return None
        try:
            data, sender = self.conn.port.recvfrom(65535)
        except OSError as exc:
            if exc.errno in (errno.EAGAIN, errno.EWOULDBLOCK, errno.ECONNREFUSED):
                return None
            raise
        if not data:
            return None
        if self.signing is not None:
            parser: Any = self.signing.parser()
        else:
            parser = mavlink2.MAVLink(None)
            parser.robust_parsing = True
        accepted = 0
        for msg in parser.parse_buffer(bytearray(data)) or []:
            if self._accepts(msg, parser):
                self.conn.post_message(msg)
                self._queued.append(msg)
                accepted += 1
        if accepted or self.signing is None:
            self._adopt_sender(sender)
        return self._queued.popleft() if self._queued else None

    def _adopt_sender(self, sender: Any) -> None:
        """Send to `sender` from now on, as pymavlink's own receive would."""
        if self.conn.udp_server:
            self.conn.clients.add(sender)
            self.conn.clients_last_alive[sender] = time.time()
        elif self.conn.broadcast:
            self.conn.last_address = sender

    def close(self) -> None:
        """Close the socket or serial port (and log the signing refusals held back)."""
        self.conn.close()
        if self.signing is not None:
            self.signing.close()


def _bind_loopback_sender(conn: Any) -> None:
    """A `udpout:` socket to a loopback peer gets a loopback source address.

    pymavlink leaves it unbound, so its first send binds it to 0.0.0.0 and it would take
    datagrams from any interface; nothing of ours listens beyond loopback unless
    configured to.
    """
    destination = getattr(conn, "destination_addr", None)
    if getattr(conn, "udp_server", True) or not destination:
        return
    try:
        if ipaddress.ip_address(destination[0]).is_loopback:
            conn.port.bind(("127.0.0.1", 0))
    except (ValueError, OSError):
        return


def text_of(msg: Any, field: str = "text") -> str:
    """A message's text field (STATUSTEXT text, PARAM_VALUE param_id) as a str."""
    raw = getattr(msg, field)
    text = raw if isinstance(raw, str) else raw.decode("utf-8", "replace")
    return str(text).rstrip("\x00")


def enum_name(enum: str, value: int) -> str:
    """The name of a MAVLink enum value, e.g. MAV_RESULT_DENIED, or ENUM(n) if unknown."""
    entry = MAV.enums.get(enum, {}).get(value)
    return entry.name if entry is not None else f"{enum}({value})"
