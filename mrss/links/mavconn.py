"""Open a pymavlink connection that speaks MAVLink 2 with the ardupilotmega dialect.

pymavlink picks its wire version from a process-wide environment variable at import
time; we set the version per connection instead, so a link and a simulator in one
process (tests) and a ground station on the other side (MAVProxy) all agree.
"""

from __future__ import annotations

import ipaddress
import select
import threading
from collections import deque
from typing import Any

from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

MAV = mavlink2  # message classes and constants of the dialect we speak


class MavConnection:
    """A pymavlink connection with a lock around sends so several threads may send."""

    def __init__(self, url: str, *, source_system: int, source_component: int,
                 udp_timeout: float = 0.0) -> None:
        self.url = url
        self.conn: Any = mavutil.mavlink_connection(
            url, source_system=source_system, source_component=source_component,
            udp_timeout=udp_timeout,
        )
        # Replace the version-1 encoder/decoder pymavlink may have chosen.
        mav = mavlink2.MAVLink(self.conn, srcSystem=source_system, srcComponent=source_component)
        mav.robust_parsing = True
        self.conn.mav = mav
        self.conn.WIRE_PROTOCOL_VERSION = "2.0"
        self.conn.first_byte = False
        self._send_lock = threading.Lock()
        self._datagrams = isinstance(self.conn, mavutil.mavudp)
        if self._datagrams:
            _bind_loopback_sender(self.conn)
        self._queued: deque[Any] = deque()

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
        if msg is None or msg.get_type() == "BAD_DATA":
            return None
        return msg

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
        readable, _, _ = select.select([self.conn.port], [], [], timeout)
        if not readable:
            return None
        data = self.conn.recv()
        if not data:
            return None
        parser = mavlink2.MAVLink(None)
        parser.robust_parsing = True
        for msg in parser.parse_buffer(bytearray(data)) or []:
            if msg.get_type() != "BAD_DATA":
                self.conn.post_message(msg)
                self._queued.append(msg)
        return self._queued.popleft() if self._queued else None

    def close(self) -> None:
        """Close the socket or serial port."""
        self.conn.close()


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
