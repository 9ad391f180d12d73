"""MAVLink UDP sockets stay on loopback: nothing of ours listens beyond it by default."""

from __future__ import annotations

from mrss.links.mavconn import MavConnection
from mrss.testing import free_udp_port


def test_udpout_to_a_loopback_peer_is_bound_to_loopback() -> None:
    conn = MavConnection(f"udpout:127.0.0.1:{free_udp_port()}", source_system=255,
                         source_component=190)
    try:
        assert conn.conn.port.getsockname()[0] == "127.0.0.1"
    finally:
        conn.conn.close()


def test_udpin_listens_on_the_address_it_was_given() -> None:
    port = free_udp_port()
    conn = MavConnection(f"udpin:127.0.0.1:{port}", source_system=1, source_component=1)
    try:
        assert conn.conn.port.getsockname() == ("127.0.0.1", port)
    finally:
        conn.conn.close()
