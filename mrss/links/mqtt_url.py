"""Broker URLs (``mqtt://[user[:password]@]host[:port]``, ``mqtts://`` for TLS) for paho,
and a robot's own login: a user name, a password file, TLS files (`with_login`).

A robot link's login (docs/robots.md, "MQTT over TLS with per-robot credentials"):
`username` and `password_file` (the password on the file's first line) replace the
URL's; `ca_certs` (the CA that signed the broker's certificate) turns TLS on, as
`mqtts://` does; `certfile` and `keyfile` are a client certificate for brokers that
want one. Without `ca_certs` TLS trusts the system's CAs.
"""

from __future__ import annotations

import socket
from dataclasses import dataclass, replace
from pathlib import Path
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
    ca_certs: str | None = None  # the CA file that verifies the broker (None: the system's)
    certfile: str | None = None  # a client certificate (PEM), for brokers that want one
    keyfile: str | None = None  # its private key (PEM)


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
        client.tls_set(ca_certs=address.ca_certs, certfile=address.certfile,
                       keyfile=address.keyfile)
    return client


MAX_PASSWORD = 4096  # bytes of a password file


def read_password(path: str) -> str:
    """The password on the first line of `path`; ConfigError(key="password_file") if the
    file is missing, unreadable, not UTF-8, too large or empty."""
    try:
        with open(path, "rb") as handle:
            data = handle.read(MAX_PASSWORD + 1)
    except OSError as exc:
        raise ConfigError(f"cannot read the password file {path!r}: {exc.strerror}",
                          key="password_file") from None
    if len(data) > MAX_PASSWORD:
        raise ConfigError(f"password file {path!r} is larger than {MAX_PASSWORD} bytes",
                          key="password_file")
    try:
        lines = data.decode("utf-8").splitlines()
    except UnicodeDecodeError:
        raise ConfigError(f"password file {path!r} is not UTF-8 text",
                          key="password_file") from None
    password = lines[0].strip() if lines else ""
    if not password:
        raise ConfigError(f"password file {path!r} is empty", key="password_file")
    return password


def with_login(address: BrokerAddress, *, username: str | None = None,
               password_file: str | None = None, ca_certs: str | None = None,
               certfile: str | None = None, keyfile: str | None = None) -> BrokerAddress:
    """`address` with a robot's own login and TLS files (module docstring); ConfigError
    (key = the option) for a file that is not there or a key file without a certificate."""
    for key, path in (("ca_certs", ca_certs), ("certfile", certfile), ("keyfile", keyfile)):
        if path is not None and not Path(path).is_file():
            raise ConfigError(f"no file {path!r}", key=key)
    if keyfile is not None and certfile is None:
        raise ConfigError("keyfile needs certfile (the client certificate)", key="keyfile")
    changes: dict[str, object] = {}
    if username is not None:
        changes.update(username=username, password=None)
    if password_file is not None:
        changes["password"] = read_password(password_file)
    if ca_certs is not None or certfile is not None:
        changes.update(tls=True, ca_certs=ca_certs, certfile=certfile, keyfile=keyfile)
    return replace(address, **changes)  # type: ignore[arg-type]


def disable_nagle(client: mqtt.Client) -> None:
    """Send small messages (commands, acks) at once instead of waiting to batch them."""
    sock = client.socket()
    if isinstance(sock, socket.socket):
        try:
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        except OSError:
            pass  # not a TCP socket (e.g. websockets); latency only
