"""Open a pymavlink connection that speaks MAVLink 2 with the ardupilotmega dialect.

pymavlink picks its wire version from a process-wide environment variable at import
time; we set the version per connection instead, so a link and a simulator in one
process (tests) and a ground station on the other side (MAVProxy) all agree.
"""

from __future__ import annotations

import threading
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

    def send(self, message: Any) -> None:
        """Encode and send one MAVLink message (thread-safe)."""
        with self._send_lock:
            self.conn.mav.send(message)

    def recv(self, timeout: float) -> Any | None:
        """The next decoded message, or None after `timeout` seconds without one."""
        msg = self.conn.recv_match(blocking=True, timeout=timeout)
        if msg is None or msg.get_type() == "BAD_DATA":
            return None
        return msg

    def close(self) -> None:
        """Close the socket or serial port."""
        self.conn.close()
