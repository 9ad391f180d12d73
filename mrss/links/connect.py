"""A robot's link from its table in project.toml, with the addresses MRSS resolves.

    [components.rcl.robots.uav1]
    link = "mavlink"        # the simulator `sim_uav` with id = "uav1" is found by itself
    [components.rcl.robots.ugv1]
    link = "mqtt"           # on the project's broker

Rules (the one place they are implemented):
- `link` names the kind (`LINK_OPTIONS` of mrss.links.factory); a table without `link`
  has no link (the layer talks to its robot some other way).
- The layer's own keys (`RobotCommLayer.robot_settings`) are set aside: never link options.
- MAVLink without `url`: the address the simulated copter of the same id wrote to the run
  folder (`<run_dir>/<robot>.mavlink`); a real vehicle gives `url = "udpin:0.0.0.0:14550"`.
  A fault campaign's relay (`<run_dir>/<robot>.mavlink.via`, mrss.config.detours) is
  put in that found address's place.
- MQTT without `broker_url`: the project's broker, `[broker] url` or the embedded
  broker's `<run_dir>/broker.url`.
- MAVLink `signing_key` is a key file relative to the project folder
  (`mrss.links.mavlink_signing`): the link signs what it sends and refuses what is not
  signed with that key.
- MQTT `username`, `password_file`, `ca_certs`, `certfile`, `keyfile` are the robot's own
  login and TLS files (`mrss.links.mqtt_url.with_login`), files relative to the project
  folder; a robot `username` replaces the project's `[broker]` login.
- HTTP needs its `url` (a robot's own API: nothing to find).
- The link checks telemetry with its robot type's limits, with the project's
  `[datalayer]` `*_range` overrides over them (mrss.edge.record_declarations).
- Every other key goes to the link factory, which checks it (unknown keys, types, the
  failsafe options of docs/robots.md).
"""

from __future__ import annotations

import threading
from collections.abc import Collection, Mapping
from pathlib import Path
from typing import Any

from mrss.config.broker import resolved_broker_url, with_login
from mrss.config.detours import detoured, via
from mrss.config.loader import load_file
from mrss.config.projects import PROJECT_FILE
from mrss.edge.validation import Rejected, limit_overrides
from mrss.errors import ConfigError
from mrss.links.base import LinkStateCallback, RobotLink, TelemetryCallback
from mrss.links.factory import create_link
from mrss.textfile import write_whole

#: The key naming a robot's link kind.
LINK_KEY = "link"
#: A MAVLink robot's key file (relative to the project folder): signing on.
SIGNING_KEY = "signing_key"
#: An MQTT robot's login and TLS files (relative to the project folder).
MQTT_FILES = ("password_file", "ca_certs", "certfile", "keyfile")
#: A simulated copter writes the address a ground station uses to `<run_dir>/<id>` + this.
ADDRESS_SUFFIX = ".mavlink"


def write_simulator_address(run_dir: Path, robot: str, url: str) -> Path:
    """Write `url` as `robot`'s simulator address in `run_dir`, atomically (a partial file
    renamed over the old one): an RCL or a test reading it while it is written sees the
    old address or the new one, never an empty file."""
    path = run_dir / f"{robot}{ADDRESS_SUFFIX}"
    write_whole(path, url + "\n")
    return path


def simulator_address(run_dir: Path | None, robot: str) -> str:
    """The MAVLink URL the simulator of `robot` wrote to the run folder (ConfigError if none)."""
    path = run_dir / f"{robot}{ADDRESS_SUFFIX}" if run_dir is not None else None
    if path is None or not path.is_file():
        raise ConfigError(f"no url, and no simulator address {robot}{ADDRESS_SUFFIX} in the run "
                          f"folder {run_dir}: start a simulator with id = {robot!r} before the "
                          "RCL, or give url", key=f"robots.{robot}.url")
    return path.read_text(encoding="utf-8").strip()


_sections_lock = threading.Lock()
_sections_seen: dict[Path, tuple[tuple[int, int], Mapping[str, Any]]] = {}


def project_sections(project_dir: Path | None) -> Mapping[str, Any]:
    """The sections of the project's project.toml ({} without one), read again only when
    the file changed (its size or modification time): an RCL connects every robot's link
    with them, and reading a fleet's file once per robot made starting 400 links take
    seconds (the parse grows with the fleet, so the reads grew with its square)."""
    path = project_dir / PROJECT_FILE if project_dir is not None else None
    if path is None or not path.is_file():
        return {}
    stat = path.stat()
    stamp = (stat.st_size, stat.st_mtime_ns)
    with _sections_lock:
        seen = _sections_seen.get(path)
        if seen is not None and seen[0] == stamp:
            return seen[1]
    sections = load_file(path).sections
    with _sections_lock:
        _sections_seen[path] = (stamp, sections)
    return sections


def project_broker_url(project_dir: Path | None, run_dir: Path | None,
                       robot: str = "") -> str | None:
    """The project's MQTT broker: `[broker] url` of project.toml, else the embedded one's
    (through a fault campaign's relay for `robot`, if one is in its path: detours),
    with the project's login (`[broker] username`, `password`/`password_env`) if any."""
    sections = project_sections(project_dir)
    url = resolved_broker_url(sections, run_dir)
    broker = sections.get("broker", {})
    configured = isinstance(broker, Mapping) and bool(broker.get("url"))
    relay = via(run_dir, robot, "mqtt") if robot and url and not configured else None
    if url and relay:
        url = detoured(url, relay)
    return with_login(url, broker) if url and isinstance(broker, Mapping) else url


def project_limits(project_dir: Path | None) -> dict[str, list[float]]:
    """The project's `[datalayer]` `*_range` limits, which its links apply too (a
    malformed one is left to the data layer and `mrss check` to report)."""
    section = project_sections(project_dir).get("datalayer", {})
    try:
        return limit_overrides(section) if isinstance(section, Mapping) else {}
    except Rejected:
        return {}


def link_options(robot: str, options: Mapping[str, Any], *, project_dir: Path | None,
                 run_dir: Path | None,
                 layer_keys: Collection[str] = ()) -> tuple[str, dict[str, Any]]:
    """(kind, link options) of a robot's table: layer keys removed, addresses resolved.

    The kind is "" when the table has no `link`.
    """
    opts = {k: v for k, v in options.items() if k not in layer_keys and k != LINK_KEY}
    kind = options.get(LINK_KEY, "")
    if not isinstance(kind, str):
        raise ConfigError(f"link must be a string, not {kind!r}", key=f"robots.{robot}.link")
    if kind == "mavlink" and "url" not in opts:
        opts["url"] = simulator_address(run_dir, robot)
        relay = via(run_dir, robot, "mavlink")  # a fault campaign's relay (detours)
        if relay:
            opts["url"] = detoured(opts["url"], relay)
    key_file = opts.get(SIGNING_KEY)
    if kind == "mavlink" and isinstance(key_file, str) and project_dir is not None:
        opts[SIGNING_KEY] = str(project_dir / key_file)
    for name in MQTT_FILES if kind == "mqtt" and project_dir is not None else ():
        if isinstance(opts.get(name), str):
            opts[name] = str(project_dir / opts[name])
    if kind == "mqtt" and "broker_url" not in opts:
        url = project_broker_url(project_dir, run_dir)
        if not url:
            raise ConfigError("no broker for the MQTT link: set [broker] url, start the "
                              "embedded broker before the RCL, or give broker_url",
                              key=f"robots.{robot}.broker_url")
        opts["broker_url"] = url
    return kind, opts


def connect_link(robot: str, options: Mapping[str, Any], *, project_dir: Path | None,
                 run_dir: Path | None, layer_keys: Collection[str] = (),
                 on_link_state: LinkStateCallback | None = None,
                 on_telemetry: TelemetryCallback | None = None) -> RobotLink | None:
    """The started link of a robot's table (None without `link`); ConfigError if misconfigured."""
    kind, opts = link_options(robot, options, project_dir=project_dir, run_dir=run_dir,
                              layer_keys=layer_keys)
    if not kind:
        return None
    link = create_link(robot, kind, opts, source=PROJECT_FILE,
                       on_link_state=on_link_state, on_telemetry=on_telemetry)
    link.limits = link.limits.overridden(project_limits(project_dir))
    link.start()
    return link
