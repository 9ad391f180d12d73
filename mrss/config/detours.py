"""Detours in a robot's path: `<run_dir>/<robot>.<link>.via` names a relay to go through.

A fault campaign (`mrss chaos`, network faults) puts a relay with real sockets between a
robot and the part of the system it talks to, so that it can delay, lose, reorder or
cut what passes (the kernel's netem, which would do it on the wire, is not in every
kernel). Before the system starts it writes, for each relayed robot link, the relay's
`HOST:PORT` to the run folder:

    <run_dir>/uav1.mavlink.via   the RCL's MAVLink link to the simulated copter uav1
    <run_dir>/ugv1.mqtt.via      the simulated UGV ugv1's connection to the MQTT broker

Whoever resolves one of these addresses by itself (the simulator's address file, the
embedded broker's `broker.url`) goes to the relay instead: `detoured` swaps the host and
port of the resolved URL, keeping its scheme and login. A configured address (`url`,
`broker_url`, `[broker] url`) is never detoured. Without a via file nothing changes.
"""

from __future__ import annotations

from pathlib import Path
from urllib.parse import urlsplit, urlunsplit

VIA_SUFFIX = ".via"


def via_file(run_dir: Path, robot: str, link: str) -> Path:
    return run_dir / f"{robot}.{link}{VIA_SUFFIX}"


def via(run_dir: Path | None, robot: str, link: str) -> str | None:
    """The `HOST:PORT` a robot's `link` goes through (None: no detour)."""
    if run_dir is None:
        return None
    path = via_file(run_dir, robot, link)
    try:
        text = path.read_text(encoding="utf-8").strip()
    except OSError:
        return None
    return text or None


def detoured(url: str, address: str) -> str:
    """`url` with its host and port replaced by `address` (`HOST:PORT`).

    `udpout:127.0.0.1:5760` (MAVLink) -> `udpout:HOST:PORT`; `mqtt://u:p@h:1883/` ->
    `mqtt://u:p@HOST:PORT/`.
    """
    if "://" in url:
        parts = urlsplit(url)
        login = parts.netloc.rpartition("@")[0]
        netloc = f"{login}@{address}" if login else address
        return urlunsplit((parts.scheme, netloc, parts.path, parts.query, parts.fragment))
    scheme, _, _ = url.partition(":")
    return f"{scheme}:{address}"
