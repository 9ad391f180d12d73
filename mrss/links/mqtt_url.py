"""Broker URLs (``mqtt://[user[:password]@]host[:port]``, ``mqtts://`` for TLS) for paho."""

from __future__ import annotations

import socket
from dataclasses import dataclass
from urllib.parse import unquote, urlsplit

from paho.mqtt import client as mqtt
from paho.mqtt.enums import CallbackAPIVersion

from mrss.errors import ConfigError


@dataclass(frozen=True)
class BrokerAddress:
    """Where an MQTT broker is and how to log in to it."""

    host: str
    port: int
    username: str | None = None
    password: str | None = None
    tls: bool = False


def parse_broker_url(url: str) -> BrokerAddress:
    """Parse a broker URL; ConfigError if the scheme, host or port is wrong."""
    parts = urlsplit(url)
    if parts.scheme not in ("mqtt", "mqtts", "tcp"):
        raise ConfigError(f"broker URL must start with mqtt:// or mqtts://: {url!r}")
    try:
        port = parts.port
    except ValueError as exc:
        raise ConfigError(f"bad port in broker URL {url!r}: {exc}") from None
    if not parts.hostname:
        raise ConfigError(f"no host in broker URL {url!r}")
    tls = parts.scheme == "mqtts"
    return BrokerAddress(
        host=parts.hostname, port=port or (8883 if tls else 1883),
        username=unquote(parts.username) if parts.username else None,
        password=unquote(parts.password) if parts.password else None, tls=tls,
    )


def new_client(client_id: str, address: BrokerAddress) -> mqtt.Client:
    """A paho 2.x client (callback API version 2) set up with `address`'s credentials."""
    client = mqtt.Client(CallbackAPIVersion.VERSION2, client_id=client_id)
    if address.username is not None:
        client.username_pw_set(address.username, address.password)
    if address.tls:
        client.tls_set()
    return client


def disable_nagle(client: mqtt.Client) -> None:
    """Send small messages (commands, acks) at once instead of waiting to batch them."""
    sock = client.socket()
    if isinstance(sock, socket.socket):
        try:
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        except OSError:
            pass  # not a TCP socket (e.g. websockets); latency only
