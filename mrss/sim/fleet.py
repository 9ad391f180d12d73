"""Many simulated robots in one process: `mrss sim fleet --uav N --ugv M`.

Each robot is the same simulator as `mrss sim uav` / `mrss sim ugv` (`SimUav`,
`SimUgv`) and speaks the real protocol on its own socket: MAVLink 2 over loopback UDP
per UAV (its own port), MQTT per UGV (its own client connection to the broker). One
thread serves them all with one `selectors` loop instead of a thread (or two) per
robot: a socket that is readable is served at once (a UAV's datagrams, a UGV's MQTT
packets), and every `step` seconds each robot flies or drives on and sends the
telemetry that is due. Telemetry rates are the same for every robot (`rate` per second:
a UAV's GLOBAL_POSITION_INT, a UGV's telemetry message).

UAV `k` (1..N) is `uav<k>`: it listens on a free loopback UDP port and, with a run
folder, writes the address a ground station uses to `<run_dir>/uav<k>.mavlink` (what
the RCL's `link = "mavlink"` reads, as for `mrss sim uav`'s component). UGV `k` is
`ugv<k>` on the broker. Homes are spread on a grid around `home`, 50 m apart.
"""

from __future__ import annotations

import argparse
import logging
import selectors
import signal
import socket
import sys
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from types import FrameType

from paho.mqtt import client as mqtt

from mrss.links.connect import write_simulator_address
from mrss.links.geo import offset
from mrss.links.mavconn import MAV
from mrss.links.ugv_protocol import DEFAULT_PREFIX
from mrss.ports import free_ports
from mrss.sim.uav import DEFAULT_HOME, SimUav
from mrss.sim.ugv import SimUgv

log = logging.getLogger("mrss.sim.fleet")

SPACING_M = 50.0
MISC_EVERY_S = 1.0  # paho's keepalive bookkeeping


@dataclass(frozen=True)
class FleetSpec:
    """What a fleet holds and how fast it talks."""

    uavs: int = 0
    ugvs: int = 0
    rate: float = 5.0  # position telemetry per second, per robot
    broker_url: str = ""  # needed when ugvs > 0
    home: tuple[float, float, float] = DEFAULT_HOME
    speedup: float = 1.0
    step: float = 0.05  # seconds between simulation steps
    prefix: str = DEFAULT_PREFIX
    run_dir: Path | None = None  # where UAV address files go


def grid_position(home: tuple[float, float, float], index: int) -> tuple[float, float]:
    """Robot `index`'s home on a square grid around `home`, SPACING_M apart."""
    side = 16
    return offset(home[0], home[1], (index // side) * SPACING_M, (index % side) * SPACING_M)


class SimFleet:
    """The robots of a `FleetSpec`, served by one event-loop thread (`start`/`stop`, or `run`)."""

    def __init__(self, spec: FleetSpec) -> None:
        if spec.uavs < 0 or spec.ugvs < 0 or spec.uavs + spec.ugvs == 0:
            raise ValueError("a fleet needs at least one robot (--uav N, --ugv M)")
        if spec.rate <= 0 or spec.step <= 0 or spec.speedup <= 0:
            raise ValueError("rate, step and speedup must be positive")
        if spec.ugvs and not spec.broker_url:
            raise ValueError("UGVs need an MQTT broker (--broker)")
        self.spec = spec
        ports = free_ports(spec.uavs, kind=socket.SOCK_DGRAM)
        self.uavs: dict[str, SimUav] = {}
        self.ports: dict[str, int] = {}
        for k, port in enumerate(ports, start=1):
            lat, lon = grid_position(spec.home, k - 1)
            uav = SimUav(f"udpin:127.0.0.1:{port}", home=(lat, lon, spec.home[2]),
                         speedup=spec.speedup)
            uav.rates[MAV.MAVLINK_MSG_ID_GLOBAL_POSITION_INT] = 1.0 / spec.rate
            self.uavs[f"uav{k}"] = uav
            self.ports[f"uav{k}"] = port
        self.ugvs: dict[str, SimUgv] = {}
        for k in range(1, spec.ugvs + 1):
            lat, lon = grid_position(spec.home, spec.uavs + k - 1)
            self.ugvs[f"ugv{k}"] = SimUgv(spec.broker_url, f"ugv{k}", prefix=spec.prefix,
                                          base=(lat, lon), speedup=spec.speedup,
                                          telemetry_hz=spec.rate)
        self._stop = threading.Event()
        self._ready = threading.Event()
        self._thread: threading.Thread | None = None
        self.error: BaseException | None = None
        self.steps = 0

    def address(self, robot: str) -> str:
        """The MAVLink URL a ground station uses to reach UAV `robot`."""
        return f"udpout:127.0.0.1:{self.ports[robot]}"

    def start(self, timeout: float = 30.0) -> SimFleet:
        """Serve on a background thread; return once every robot's socket is open."""
        self._thread = threading.Thread(target=self._run_safely, name="sim-fleet", daemon=True)
        self._thread.start()
        if not self._ready.wait(timeout):
            raise TimeoutError(f"the fleet did not open its sockets within {timeout}s")
        if self.error is not None:
            raise self.error
        return self

    def alive(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=10)

    def _run_safely(self) -> None:
        try:
            self.run()
        except BaseException as exc:
            self.error = exc
            log.exception("the fleet stopped")
        finally:
            self._ready.set()

    def run(self) -> None:
        """Serve every robot until `stop()`."""
        sel = selectors.DefaultSelector()
        try:
            for uav in self.uavs.values():
                uav.open()
                sel.register(uav.fileno(), selectors.EVENT_READ, uav)
            for ugv in self.ugvs.values():
                client = ugv.connect()
                sock = client.socket()
                assert sock is not None
                sel.register(sock, selectors.EVENT_READ, ugv)
            self._write_addresses()
            self._ready.set()
            log.info("fleet: %d UAV(s), %d UGV(s), telemetry %g/s each", len(self.uavs),
                     len(self.ugvs), self.spec.rate)
            self._serve(sel)
        finally:
            for ugv in self.ugvs.values():
                try:
                    ugv.close()
                except Exception:  # a broker gone already: nothing to say goodbye to
                    log.debug("closing %s failed", ugv.robot_id, exc_info=True)
            for uav in self.uavs.values():
                uav.close()
            sel.close()

    def _serve(self, sel: selectors.BaseSelector) -> None:
        step = self.spec.step
        next_step = time.monotonic()
        next_misc = next_step + MISC_EVERY_S
        ugvs = list(self.ugvs.values())
        while not self._stop.is_set():
            now = time.monotonic()
            for key, _ in sel.select(max(0.0, next_step - now)):
                robot = key.data
                if isinstance(robot, SimUav):
                    robot.receive()
                else:
                    self._read_mqtt(sel, key.fileobj, robot)
            now = time.monotonic()
            if now >= next_step:
                self.steps += 1
                for uav in self.uavs.values():
                    uav.tick(now)
                for ugv in ugvs:
                    ugv.tick(now)
                    self._flush_mqtt(ugv)
                next_step = max(next_step + step, now - step)
            if now >= next_misc:
                next_misc = now + MISC_EVERY_S
                for ugv in ugvs:
                    ugv.client.loop_misc()

    def _read_mqtt(self, sel: selectors.BaseSelector, fileobj: object, ugv: SimUgv) -> None:
        client = ugv.client
        if client.loop_read() != mqtt.MQTT_ERR_SUCCESS:
            log.warning("%s: broker connection lost; reconnecting", ugv.robot_id)
            sel.unregister(fileobj)  # type: ignore[arg-type]
            try:
                client.reconnect()
            except OSError as exc:
                log.warning("%s: reconnect failed: %s", ugv.robot_id, exc)
                return
            sock = client.socket()
            if sock is not None:
                sel.register(sock, selectors.EVENT_READ, ugv)
            return
        self._flush_mqtt(ugv)

    @staticmethod
    def _flush_mqtt(ugv: SimUgv) -> None:
        client = ugv.client
        if client.want_write():
            client.loop_write()

    def _write_addresses(self) -> None:
        run_dir = self.spec.run_dir
        if run_dir is None:
            return
        for robot in self.uavs:
            write_simulator_address(run_dir, robot, self.address(robot))


# -- command line ----------------------------------------------------------------------------
def configure(parser: argparse.ArgumentParser) -> None:
    """Add the fleet's options to `parser`."""
    parser.add_argument("--uav", type=int, default=0, help="simulated UAVs (MAVLink over UDP)")
    parser.add_argument("--ugv", type=int, default=0, help="simulated UGVs (MQTT)")
    parser.add_argument("--broker", default="", help="MQTT broker URL (needed with --ugv)")
    parser.add_argument("--rate", type=float, default=5.0,
                        help="position telemetry per second per robot (default 5)")
    parser.add_argument("--speedup", type=float, default=1.0,
                        help="simulated seconds per wall-clock second")
    parser.add_argument("--run-dir", default=None,
                        help="write each UAV's address (uav<k>.mavlink) into this folder")


def run(args: argparse.Namespace) -> int:
    """Run the fleet until SIGINT/SIGTERM; returns the exit code."""
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s %(message)s")
    try:
        fleet = SimFleet(FleetSpec(
            uavs=args.uav, ugvs=args.ugv, rate=args.rate, broker_url=args.broker,
            speedup=args.speedup, run_dir=Path(args.run_dir) if args.run_dir else None))
    except ValueError as exc:
        print(f"mrss sim fleet: {exc}", file=sys.stderr)
        return 2

    def stop(signum: int, frame: FrameType | None) -> None:
        fleet.stop()

    signal.signal(signal.SIGTERM, stop)
    signal.signal(signal.SIGINT, stop)
    for robot in fleet.uavs:
        print(f"{robot} {fleet.address(robot)}", flush=True)
    try:
        fleet.run()
    except OSError as exc:
        print(f"mrss sim fleet: {exc}", file=sys.stderr)
        return 1
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="mrss sim fleet", description=__doc__)
    configure(parser)
    return run(parser.parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
