"""The simulated robots as supervised components: `mrss supervise` runs them like any part.

    [components.sim_uav]
    kind = "sim_uav"
    id = "uav1"                       # names the address file: <run_dir>/uav1.mavlink
    home = [-35.363262, 149.165237, 584.0]
    hotspots = [{lat = -35.3604, lon = 149.1657, temperature = 450}]   # or "FILE" / "LAT,LON;..."
    speedup = 4.0                     # $MRSS_SIM_SPEEDUP overrides (tests run faster)
    endurance = 600.0                 # seconds of hover on a full battery (SIM_ENDURANCE)
    recharge = 5.0                    # % per simulated second, landed and disarmed at home
    camera_radius = 25.0
    port = 0                          # UDP port to listen on; 0: a free one
    failsafe = "hold"                 # GCS failsafe: hold | rtl | stop (FS_GCS_ENABLE 7/1/5)
    failsafe_timeout = 5.0            # seconds without GCS heartbeats (FS_GCS_TIMEOUT)
    signing_key = "keys/uav1.key"     # MAVLink 2 signing (the robot's link names the same file)

    [components.sim_ugv]
    kind = "sim_ugv"
    id = "ugv1"
    base = [-35.3635, 149.165]
    speedup = 4.0                     # $MRSS_SIM_SPEEDUP overrides
    # tank = 200.0, pump_rate = 5.0, speed = 3.0, rate = 2.0, prefix = "mrss/robots"
    # broker_url = "mqtt://..."       # default: the project's broker (run_dir/broker.url)
    failsafe = "stop"                 # without controller heartbeats: hold | rtl | stop
    failsafe_timeout = 5.0

Without `failsafe` a simulator has no failsafe of its own; the robot's link may still
configure one (`failsafe` in the RCL's robot table). See docs/robots.md, "Failsafe".

The UAV listens on a loopback UDP port and writes the connection string a ground
station uses to reach it (`udpout:127.0.0.1:PORT`) to `<run_dir>/<id>.mavlink`, as the
embedded broker writes `broker.url`; a restarted incarnation reuses that port, so a
connected link just carries on. Nothing is fixed, so parallel runs never collide.
"""

from __future__ import annotations

import logging
import os
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, ClassVar

from mrss.errors import ConfigError
from mrss.links.connect import ADDRESS_SUFFIX, write_simulator_address
from mrss.links.connect import project_broker_url as links_broker_url
from mrss.links.failsafe import policy_of
from mrss.links.geo import distance_m
from mrss.links.mavlink_signing import load_key
from mrss.options import Check, Option
from mrss.ports import free_udp_port
from mrss.runtime.component import Component, ComponentContext
from mrss.sim.hotspots import Hotspot, hotspots_from_records, parse_hotspots
from mrss.sim.uav import DEFAULT_HOME, SimUav
from mrss.sim.ugv import DEFAULT_BASE, SimUgv
from mrss.sim.ugv_model import UgvParams

log = logging.getLogger("mrss.sim")

SPEEDUP_ENV = "MRSS_SIM_SPEEDUP"
HOME_RADIUS_M = 10.0


def defaults_of(declared: Sequence[Option]) -> dict[str, Any]:
    """Each declared option's default: the one place it is written."""
    return {option.name: option.default for option in declared}


def speedup_of(options: Mapping[str, Any]) -> float:
    """The simulated seconds per wall-clock second: $MRSS_SIM_SPEEDUP, else `speedup`."""
    raw: Any = os.environ.get(SPEEDUP_ENV) or options.get("speedup", 1.0)
    try:
        value = float(raw)
    except (TypeError, ValueError):
        raise ConfigError(f"speedup must be a number, not {raw!r}", key="speedup") from None
    if value <= 0:
        raise ConfigError("speedup must be positive", key="speedup")
    return value


def number(options: Mapping[str, Any], key: str, default: float, *, low: float = 0.0) -> float:
    """A numeric option (ints accepted), at least `low`; ConfigError names the key."""
    value = options.get(key, default)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or value < low:
        raise ConfigError(f"must be a number >= {low:g}, not {value!r}", key=key)
    return float(value)


def position(options: Mapping[str, Any], key: str, default: Sequence[float],
             size: int) -> tuple[float, ...]:
    """`[lat, lon(, alt)]` or "lat,lon(,alt)"; the altitude may be left out (0)."""
    value: Any = options.get(key, list(default))
    if isinstance(value, str):
        value = value.split(",")
    try:
        values = [float(v) for v in value]
    except (TypeError, ValueError):
        raise ConfigError(f"must be [lat, lon{', alt' if size == 3 else ''}], not {value!r}",
                          key=key) from None
    if len(values) == 2 and size == 3:
        values.append(0.0)
    if len(values) != size or not (-90 <= values[0] <= 90 and -180 <= values[1] <= 180):
        raise ConfigError(f"must be [lat, lon{', alt' if size == 3 else ''}], not {value!r}",
                          key=key)
    return tuple(values)


def hotspots_of(options: Mapping[str, Any], project_dir: Path) -> list[Hotspot]:
    """Hidden hotspots: a list of tables, or a file (relative to the project) / inline text."""
    value = options.get("hotspots", [])
    if isinstance(value, list):
        return hotspots_from_records(value, "project.toml")
    if isinstance(value, str):
        candidate = project_dir / value
        return parse_hotspots(str(candidate) if value and candidate.is_file() else value)
    raise ConfigError("must be a list of {lat, lon} tables or a string", key="hotspots")


def signing_key_of(options: Mapping[str, Any], project_dir: Path) -> bytes | None:
    """The `signing_key` file's key (relative to the project folder), or None."""
    value = options.get("signing_key")
    if value is None:
        return None
    if not isinstance(value, str):
        raise ConfigError(f"must be a key file name, not {value!r}", key="signing_key")
    return load_key(value, project_dir)


class GroundCrewUav(SimUav):
    """The simulated copter, plus a ground crew that charges its battery at home.

    While the vehicle is landed and disarmed within 10 m of home, its battery gains
    `recharge_pct_per_s` percent per simulated second (a battery swap, seen from afar).
    """

    def __init__(self, url: str, *, recharge_pct_per_s: float = 0.0, **kwargs: Any) -> None:
        super().__init__(url, **kwargs)
        self.recharge_pct_per_s = recharge_pct_per_s

    def _advance(self, dt: float) -> None:
        super()._advance(dt)
        m = self.model
        if (self.recharge_pct_per_s > 0 and m.landed and not m.armed and m.battery_pct < 100.0
                and distance_m(m.lat, m.lon, m.home_lat, m.home_lon) <= HOME_RADIUS_M):
            m.battery_pct = min(100.0, m.battery_pct + self.recharge_pct_per_s * dt)

    def listening(self) -> bool:
        """Whether the vehicle's socket is open (its thread started and bound the port)."""
        return self._conn is not None


class SimUavComponent(Component):
    """A simulated UAV (MAVLink over loopback UDP) as a supervised component."""

    #: The options this component reads (`mrss check` validates them; docs/config.md).
    OPTIONS: ClassVar[tuple[Option, ...]] = (
        Option("id", str, "uav1", "the robot id (its address file is <run_dir>/<id>.mavlink)"),
        Option("home", list, list(DEFAULT_HOME), "[lat, lon, alt] of home", Check.POSITION),
        Option("hotspots", (list, str), [], "hidden hotspots: tables, or a JSON file"),
        Option("speedup", float, 1.0, "simulated time per real second ($MRSS_SIM_SPEEDUP wins)",
               Check.POSITIVE),
        Option("endurance", float, None, "hover seconds on a full battery", Check.POSITIVE),
        Option("recharge", float, 5.0, "% per second while landed at home", Check.NON_NEGATIVE),
        Option("port", int, 0, "UDP port (0: a free one)", Check.PORT),
        Option("sysid", int, 1, "MAVLink system id", Check.POSITIVE),
        Option("camera_radius", float, 25.0, "metres the thermal camera sees", Check.POSITIVE),
        Option("failsafe", str, None, "what the vehicle does without a controller"),
        Option("failsafe_timeout", float, None, "seconds without a controller", Check.POSITIVE),
        Option("signing_key", str, None, "MAVLink 2 signing key file (64 hex characters)",
               Check.SIGNING_KEY),
    )

    def __init__(self) -> None:
        self.uav: GroundCrewUav | None = None
        self.address_file: Path | None = None

    def start(self, ctx: ComponentContext) -> None:
        opts, default = ctx.options, defaults_of(self.OPTIONS)
        robot = str(opts.get("id", default["id"]))
        home = position(opts, "home", default["home"], 3)
        self.address_file = ctx.run_dir / f"{robot}{ADDRESS_SUFFIX}"
        port = int(number(opts, "port", default["port"])) or self._previous_port() \
            or free_udp_port()
        uav = GroundCrewUav(
            f"udpin:127.0.0.1:{port}", sysid=int(number(opts, "sysid", default["sysid"], low=1)),
            home=(home[0], home[1], home[2]), hotspots=hotspots_of(opts, ctx.project_dir),
            speedup=speedup_of(opts),
            camera_radius_m=number(opts, "camera_radius", default["camera_radius"]),
            recharge_pct_per_s=number(opts, "recharge", default["recharge"]),
            failsafe=policy_of(opts), signing_key=signing_key_of(opts, ctx.project_dir))
        uav.model.params.endurance_s = number(opts, "endurance", uav.model.params.endurance_s,
                                              low=1.0)
        uav.start()
        deadline = time.monotonic() + 5.0
        while not uav.listening():
            if uav._thread is None or not uav._thread.is_alive() or time.monotonic() > deadline:
                raise ConfigError(f"simulated {robot} could not listen on UDP port {port}",
                                  key="port")
            time.sleep(0.01)
        self.uav = uav
        write_simulator_address(ctx.run_dir, robot, f"udpout:127.0.0.1:{port}")
        ctx.log.info("simulated %s: MAVLink on udp 127.0.0.1:%d (link url in %s), home %.6f,"
                     "%.6f, %d hidden hotspots, speedup %g", robot, port, self.address_file,
                     home[0], home[1], len(uav.camera.hotspots), uav.speedup)

    def _previous_port(self) -> int:
        """The port an earlier incarnation of this run listened on (0 if none)."""
        if self.address_file is None or not self.address_file.is_file():
            return 0
        try:
            return int(self.address_file.read_text(encoding="utf-8").strip().rsplit(":", 1)[1])
        except (IndexError, ValueError):
            return 0

    def healthy(self) -> bool:
        thread = self.uav._thread if self.uav is not None else None
        return thread is not None and thread.is_alive()

    def stop(self) -> None:
        if self.uav is not None:
            self.uav.stop()


def project_broker_url(ctx: ComponentContext, robot: str = "") -> str:
    """`broker_url` of the component, else the project's broker (configured or embedded;
    the embedded one through a fault campaign's relay for `robot`: mrss.config.detours)."""
    url = ctx.options.get("broker_url")
    if isinstance(url, str) and url:
        return url
    resolved = links_broker_url(ctx.project_dir, ctx.run_dir, robot)   # the links' own rule
    if not resolved:
        raise ConfigError("no MQTT broker: set [broker] url, start the embedded broker "
                          "before this component, or give broker_url", key="broker_url")
    return resolved


class SimUgvComponent(Component):
    """A simulated UGV (JSON over the project's MQTT broker) as a supervised component."""

    #: The options this component reads (`mrss check` validates them; docs/config.md).
    OPTIONS: ClassVar[tuple[Option, ...]] = (
        Option("id", str, "ugv1", "the robot id"),
        Option("base", list, list(DEFAULT_BASE), "[lat, lon] of the base", Check.POSITION),
        Option("speed", float, None, "m/s", Check.POSITIVE),
        Option("tank", float, None, "litres of water", Check.POSITIVE),
        Option("pump_rate", float, None, "litres per second", Check.POSITIVE),
        Option("broker_url", str, None, "MQTT broker (default: the project's)", Check.URL),
        Option("prefix", str, None, "MQTT topic prefix"),
        Option("rate", float, 2.0, "telemetry per second", Check.POSITIVE),
        Option("speedup", float, 1.0, "simulated time per real second", Check.POSITIVE),
        Option("failsafe", str, None, "what the vehicle does without a controller"),
        Option("failsafe_timeout", float, None, "seconds without a controller", Check.POSITIVE),
        Option("username", str, None, "the robot's own MQTT login (docs/robots.md)"),
        Option("password_file", str, None, "its password (first line)", Check.PROJECT_FILE),
        Option("ca_certs", str, None, "the CA of the broker's certificate: TLS",
               Check.PROJECT_FILE),
        Option("certfile", str, None, "a TLS client certificate", Check.PROJECT_FILE),
        Option("keyfile", str, None, "its private key", Check.PROJECT_FILE),
    )
    LOGIN = ("username", "password_file", "ca_certs", "certfile", "keyfile")

    def __init__(self) -> None:
        self.ugv: SimUgv | None = None

    def start(self, ctx: ComponentContext) -> None:
        opts, default = ctx.options, defaults_of(self.OPTIONS)
        robot = str(opts.get("id", default["id"]))
        base = position(opts, "base", default["base"], 2)
        defaults = UgvParams()
        params = UgvParams(
            max_speed_mps=number(opts, "speed", defaults.max_speed_mps, low=0.1),
            tank_capacity_l=number(opts, "tank", defaults.tank_capacity_l, low=1.0),
            pump_rate_lps=number(opts, "pump_rate", defaults.pump_rate_lps, low=0.1))
        url = project_broker_url(ctx, robot)
        prefix = opts.get("prefix")
        extra: dict[str, Any] = {"prefix": str(prefix)} if prefix else {}
        self.ugv = SimUgv(url, robot, base=(base[0], base[1]), params=params,
                          speedup=speedup_of(opts),
                          telemetry_hz=number(opts, "rate", default["rate"], low=0.1),
                          failsafe=policy_of(opts), login=self._login(ctx), **extra)
        self.ugv.start()
        ctx.log.info("simulated %s on %s, base %.6f,%.6f, tank %g l, speedup %g", robot, url,
                     base[0], base[1], params.tank_capacity_l, self.ugv.speedup)

    def _login(self, ctx: ComponentContext) -> dict[str, str]:
        """The robot's own MQTT login and TLS files (files relative to the project)."""
        login: dict[str, str] = {}
        for name in self.LOGIN:
            value = ctx.options.get(name)
            if value is None:
                continue
            if not isinstance(value, str) or not value:
                raise ConfigError(f"must be a non-empty string, not {value!r}", key=name)
            login[name] = value if name == "username" else str(ctx.project_dir / value)
        return login

    def healthy(self) -> bool:
        thread = self.ugv._thread if self.ugv is not None else None
        return thread is not None and thread.is_alive()

    def stop(self) -> None:
        if self.ugv is not None:
            self.ugv.stop()
