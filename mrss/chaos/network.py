"""The network paths a campaign can impair: robot links through relays, nodes through nftables.

Robot links (`Relays`): before the system starts, each simulated robot whose link MRSS
finds by itself gets a relay (mrss.chaos.relay) and a via file (mrss.config.detours):

- a MAVLink robot (`link = "mavlink"`, no `url`, a `sim_uav` of that id): a `UdpRelay`
  between the RCL's link and the simulator's UDP port (`<run_dir>/<robot>.mavlink`);
- a simulated MQTT robot (`sim_ugv` of that id, no `broker_url`, no `[broker] url`): a
  `TcpRelay` between the robot's MQTT client and the embedded broker (`broker.url`).
  The RCL's own connection to the broker does not pass it: a partition cuts the
  broker from that one robot only.

A fault on a robot link is an `Impairment` on its relay, healed by taking it off again.

Between nodes (`NodeFilter`): an nftables table of its own (`inet mrss_chaos`) in the
campaign's network namespace, with one rule per fault on a peer node's address: `drop`
(a partition) or `numgen random mod 100 < N drop` (loss of N %); its heal deletes the
rule. The kernel does this on real packets; it needs root and the `nft` command, and a
project on `[nodes]`: a campaign on one host has no node to cut off (`why_no_nodes`).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import threading
from collections.abc import Callable
from pathlib import Path

from mrss.chaos.relay import Address, Impairment, Impairments, TcpRelay, UdpRelay
from mrss.config.broker import BROKER_URL_FILE, table
from mrss.config.detours import via_file
from mrss.config.kinds import ComponentKind
from mrss.config.project import ProjectConfig
from mrss.errors import MrssError
from mrss.links.connect import ADDRESS_SUFFIX
from mrss.links.mqtt_url import parse_broker_url
from mrss.textfile import write_whole

Heal = Callable[[], None]
NFT_TABLE = "mrss_chaos"


class NetworkError(MrssError):
    """A network fault that cannot be injected here (no relay, no root, no nft)."""


def relayed_robots(config: ProjectConfig) -> dict[str, str]:
    """robot -> its link kind ("mavlink" | "mqtt"), for the robots a relay can stand before."""
    sims = {str(c.options.get("id")): c.kind for c in config.components if c.enabled
            and c.kind in (ComponentKind.SIM_UAV, ComponentKind.SIM_UGV)}
    configured_broker = bool(table(config.sections, "broker").get("url"))
    out: dict[str, str] = {}
    for rcl in config.of_kind(ComponentKind.RCL):
        robots = rcl.options.get("robots") or {}
        for robot, opts in robots.items() if isinstance(robots, dict) else ():
            if not isinstance(opts, dict):
                continue
            link = opts.get("link")
            if link == "mavlink" and "url" not in opts and sims.get(robot) \
                    is ComponentKind.SIM_UAV:
                out[robot] = "mavlink"
            elif link == "mqtt" and sims.get(robot) is ComponentKind.SIM_UGV \
                    and not configured_broker:
                sim = next(c for c in config.components if c.options.get("id") == robot)
                if not sim.options.get("broker_url"):
                    out[robot] = "mqtt"
    return out


class Relays:
    """A relay for each relayed robot of a project, its via file in the run folder."""

    def __init__(self, config: ProjectConfig, run_dir: Path, seed: int) -> None:
        self.run_dir = run_dir
        self.links = relayed_robots(config)
        self.impairments: dict[str, Impairments] = {}
        self.relays: dict[str, UdpRelay | TcpRelay] = {}
        for n, (robot, link) in enumerate(sorted(self.links.items())):
            impairments = Impairments(seed=seed * 1000 + n)
            relay: UdpRelay | TcpRelay
            if link == "mavlink":
                relay = UdpRelay(self._simulator(robot), impairments)
            else:
                relay = TcpRelay(self._broker, impairments)
            self.impairments[robot], self.relays[robot] = impairments, relay

    def start(self) -> Relays:
        for robot, relay in self.relays.items():
            relay.start()
            host, port = relay.address
            write_whole(via_file(self.run_dir, robot, self.links[robot]), f"{host}:{port}\n")
        return self

    def close(self) -> None:
        for relay in self.relays.values():
            relay.close()

    def impair(self, robot: str, kind: Impairment, amount: float) -> Heal:
        if robot not in self.impairments:
            raise NetworkError(f"{robot}: no relay in its link's path")
        if self.links[robot] == "mqtt" and kind is Impairment.REORDER:
            raise NetworkError(f"{robot}: {kind} does not apply to a TCP link (MQTT)")
        return self.impairments[robot].add(kind, amount)

    def counts(self) -> dict[str, dict[str, int]]:
        return {robot: dict(relay.counts) for robot, relay in self.relays.items()}

    def _simulator(self, robot: str) -> Callable[[], Address | None]:
        path = self.run_dir / f"{robot}{ADDRESS_SUFFIX}"
        return _cached(path, _udp_address)

    def _broker(self) -> Address | None:
        try:
            address = parse_broker_url(
                (self.run_dir / BROKER_URL_FILE).read_text(encoding="utf-8").strip())
        except (OSError, MrssError):
            return None
        return address.host, address.port


def _udp_address(text: str) -> Address | None:
    """`udpout:HOST:PORT` -> (HOST, PORT)."""
    _, host, port = text.strip().rsplit(":", 2) if text.count(":") >= 2 else ("", "", "")
    return (host, int(port)) if host and port.isdigit() else None


def _cached(path: Path, parse: Callable[[str], Address | None]
            ) -> Callable[[], Address | None]:
    """The address in `path`, read again only when the file changed (a restarted
    simulator rewrites it)."""
    seen: list[tuple[float, Address | None]] = []
    lock = threading.Lock()

    def address() -> Address | None:
        try:
            mtime = path.stat().st_mtime
        except OSError:
            return seen[0][1] if seen else None
        with lock:
            if not seen or seen[0][0] != mtime:
                try:
                    value = parse(path.read_text(encoding="utf-8"))
                except OSError:
                    value = None
                seen[:] = [(mtime, value)]
            return seen[0][1]
    return address


# -- between nodes: nftables ------------------------------------------------------------------
def why_no_nft() -> str:
    """Why nftables rules cannot be set here ("" when they can)."""
    if os.geteuid() != 0:
        return "needs root (nftables rules)"
    if shutil.which("nft") is None:
        return "the nft command (package nftables) is not installed"
    return ""


class NodeFilter:
    """nftables rules that drop traffic to and from peer addresses (this namespace)."""

    def __init__(self, table_name: str = NFT_TABLE, prefix: tuple[str, ...] = ()) -> None:
        self.table = table_name
        self.prefix = prefix  # e.g. ("ip", "netns", "exec", NAME): that namespace's rules
        self._lock = threading.Lock()
        self._made = False

    def cut(self, address: str, loss_percent: int = 100) -> Heal:
        """Drop packets to and from `address` (all of them, or `loss_percent` % at random)."""
        if why_no_nft():
            raise NetworkError(why_no_nft())
        verdict = "drop" if loss_percent >= 100 else \
            f"numgen random mod 100 < {int(loss_percent)} drop"
        family = "ip6" if ":" in address else "ip"
        with self._lock:
            if not self._made:
                self._nft(f"add table inet {self.table}")
                for hook in ("input", "output"):
                    self._nft(f"add chain inet {self.table} {hook} "
                              f"{{ type filter hook {hook} priority -10 ; }}")
                self._made = True
            handles = [self._add(hook, f"{family} {direction} {address} {verdict}")
                       for hook, direction in (("input", "saddr"), ("output", "daddr"))]
        healed = False

        def heal() -> None:
            nonlocal healed
            with self._lock:
                if healed or not self._made:
                    return
                healed = True
                for hook, handle in zip(("input", "output"), handles, strict=True):
                    self._nft(f"delete rule inet {self.table} {hook} handle {handle}")
        return heal

    def close(self) -> None:
        with self._lock:
            if self._made:
                self._nft(f"delete table inet {self.table}", check=False)
                self._made = False

    def _add(self, hook: str, rule: str) -> int:
        out = self._nft(f"-e -a add rule inet {self.table} {hook} {rule}")
        for word, after in zip(out.split(), out.split()[1:], strict=False):
            if word == "handle":
                return int(after)
        raise NetworkError(f"nft gave no handle for rule {rule!r}: {out!r}")

    def _nft(self, command: str, check: bool = True) -> str:
        done = subprocess.run([*self.prefix, "nft", *command.split()], capture_output=True,
                              text=True, timeout=10, check=False)
        if check and done.returncode != 0:
            raise NetworkError(f"nft {command}: {done.stderr.strip()}")
        return done.stdout
