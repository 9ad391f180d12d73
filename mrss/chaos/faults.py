"""The faults of a campaign: what each kind does to a running system, and its targets.

Every fault is a real signal (or resource limit) sent to a real process of the system
under `mrss supervise`, the way an outside killer, a hung machine or a full disk would:

    kill        SIGKILL a component's process
    hang        SIGSTOP a component's process for `duration` s, then SIGCONT
    blackout    SIGSTOP the bus proxy for `duration` s: nobody hears anybody
    broker      SIGKILL the embedded MQTT broker (the supervisor restarts it)
    link        SIGSTOP a robot simulator for `duration` s: the robot's link goes silent
    forkserver  SIGKILL the root supervisor's fork server (its child process)
    disk_full   the RCL process's file size limit (RLIMIT_FSIZE) drops to 0 for
                `duration` s: every write to a file (journal, log) fails with EFBIG, as on
                a full disk; Python ignores SIGXFSZ, so the process lives on

Network faults, for `duration` s, on a robot's link through the relay the campaign put
in its path (mrss.chaos.network, mrss.chaos.relay; the kernel's netem is not in every
kernel, and components of one node talk over unix sockets no packet filter sees):

    delay           everything either way held 0.5 s (MAVLink UDP, MQTT TCP)
    loss            each MAVLink datagram either way dropped with probability 0.3; on
                    MQTT (TCP), what TCP shows of such a link: each chunk of bytes
                    stalled 1 s with probability 0.3, or (a tenth of those) its
                    connection reset
    reorder         each MAVLink datagram held 0.15 s more with probability 0.3: later
                    ones overtake it
    partition       nothing passes: a MAVLink robot out of reach, or the MQTT broker cut
                    from one robot (its bytes wait; the RCL's own connection is not cut)

and one that is never healed, drawn only when named (not in `all`):

    robot_loss      a robot taken away for good, mid-task: its link's relay lets nothing
                    through for the rest of the campaign (a robot destroyed, or gone out
                    of range for good); its simulator runs on, so no supervisor brings
                    it back. The campaign waits (up to `MID_TASK_WAIT` s) until the robot
                    has just begun a task addressed to a role (within `FRESH_TASK` s: the
                    loss is known only after the link's timeout, so the task's work must
                    lie ahead), and records the tasks it held. Each robot is lost at most
                    once

and between nodes, by the kernel (nftables rules in the campaign's network namespace,
needing root, `nft` and a project on [nodes]; without them the kinds have no target,
and the reason is given):

    node_partition  every packet to and from a peer node's address dropped
    node_loss       30 % of the packets to and from it dropped at random
    node_delay      everything either way between the nodes held 0.2 s (to 0.4 s: a
                    chunk arriving while one is held waits for it too), in relays the
                    campaign put between the nodes before they started (nftables NAT
                    redirects; mrss.chaos.node_relays) since netem is not in every kernel

Targets come from the project's components by module (`targets`). A pid is checked to be
a descendant of the root supervisor before any signal, so a recycled pid is never hit.
A timed fault returns its `heal`, which the campaign calls when the duration is over
(also when the campaign stops early); healing a process that died meanwhile is a no-op.
Timed faults on one process may overlap (a second hang of a hung process, a second
full disk): the process is resumed, or its file size limit given back, when the last
of them is over, never by the first heal while another is still on (a second full disk
would otherwise save the limit of 0 and "restore" it for ever).
"""

from __future__ import annotations

import os
import signal
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path

import psutil

from mrss.chaos.netns import NodeNetwork, why_no_netns
from mrss.chaos.network import NetworkError, Relays, relayed_robots, why_no_nft
from mrss.chaos.relay import Impairment
from mrss.config.kinds import ComponentKind
from mrss.config.nodes import node_plan
from mrss.config.project import ProjectConfig
from mrss.errors import MrssError
from mrss.runtime.forkserver import is_fork_server

SIMULATORS = (ComponentKind.SIM_UAV, ComponentKind.SIM_UGV, ComponentKind.SIM_FLEET)
FORKSERVER = "forkserver"
SIGXFSZ_BIT = 1 << (signal.SIGXFSZ - 1)


class FaultKind(StrEnum):
    KILL = "kill"
    HANG = "hang"
    BLACKOUT = "blackout"
    BROKER = "broker"
    LINK = "link"
    FORKSERVER = "forkserver"
    DISK_FULL = "disk_full"
    DELAY = "delay"
    LOSS = "loss"
    REORDER = "reorder"
    PARTITION = "partition"
    NODE_PARTITION = "node_partition"
    NODE_LOSS = "node_loss"
    NODE_DELAY = "node_delay"
    ROBOT_LOSS = "robot_loss"

    @property
    def permanent(self) -> bool:
        """Whether the fault is never healed (drawn only when named: not in `all`)."""
        return self is FaultKind.ROBOT_LOSS

    @property
    def timed(self) -> bool:
        """Whether the fault lasts (and is healed) rather than happening once."""
        return self in (FaultKind.HANG, FaultKind.BLACKOUT, FaultKind.LINK,
                        FaultKind.DISK_FULL) or self.network

    @property
    def network(self) -> bool:
        """Whether the fault is on the network (a relay or packet filter), not a process."""
        return self in NETWORK_AMOUNTS

    @property
    def amount(self) -> float:
        """How strong a network fault is (s of delay, probability, % of packets)."""
        return NETWORK_AMOUNTS.get(self, 0.0)


#: Each network kind's strength: the relay's impairment, or the % of packets dropped.
NETWORK_AMOUNTS: dict[FaultKind, float] = {
    FaultKind.DELAY: 0.5, FaultKind.LOSS: 0.3, FaultKind.REORDER: 0.3,
    FaultKind.PARTITION: 0.0, FaultKind.NODE_PARTITION: 100.0, FaultKind.NODE_LOSS: 30.0,
    FaultKind.NODE_DELAY: 0.2}
#: What `--kinds all` draws from: every kind but those never healed.
ALL_KINDS = tuple(k for k in FaultKind if not k.permanent)
#: Seconds a robot_loss waits for its robot to be mid-task before it strikes anyway.
MID_TASK_WAIT = 30.0
FRESH_TASK = 1.0  # a robot_loss strikes a task begun at most this long ago
#: The kinds between nodes (a project on [nodes], in network namespaces).
NODE_KINDS = (FaultKind.NODE_PARTITION, FaultKind.NODE_LOSS, FaultKind.NODE_DELAY)
#: The relay's impairment for each network kind on a robot link.
IMPAIRMENTS = {FaultKind.DELAY: Impairment.DELAY, FaultKind.LOSS: Impairment.LOSS,
               FaultKind.REORDER: Impairment.REORDER, FaultKind.PARTITION: Impairment.PARTITION}


class InjectionError(MrssError):
    """A fault could not be injected (no such process, not allowed)."""


@dataclass(frozen=True)
class Fault:
    """One planned fault: when (s after the faults begin), what, on whom, how long."""

    at: float
    kind: FaultKind
    target: str
    duration: float = 0.0
    amount: float = 0.0  # a network fault's strength (FaultKind.amount)


Heal = Callable[[], None]


class Effect(StrEnum):
    """What a timed fault does to a process, which overlapping faults share."""

    STOPPED = "stopped"      # SIGSTOP until SIGCONT: hang, blackout, link
    DISK_FULL = "disk_full"  # RLIMIT_FSIZE 0 until the saved limit is back


def targets(config: ProjectConfig, only: Iterable[str] = ()) -> dict[FaultKind, list[str]]:
    """The possible targets of each fault kind in this project (empty list: not possible;
    `unavailable` says why).

    `only` limits `kill` and `hang` to those components (targeted campaigns). On
    `[nodes]`, processes are hit on the campaign's own node (`home_node`) only, and the
    node kinds hit its peers, when each node can have a namespace of its own here.
    """
    home = home_node(config)
    plan = node_plan(config)
    enabled = [c for c in config.components if c.enabled
               and plan.placement.get(c.id, "") in ("", home)]
    relayed = relayed_robots(config)
    nodes = sorted(n for n in plan.nodes if n != home) \
        if home and not why_no_nodes(config) else []
    names = [c.id for c in enabled]
    chosen = [n for n in names if n in set(only)] if only else names

    def by(*kinds: ComponentKind) -> list[str]:
        return [c.id for c in enabled if c.kind in kinds]

    return {
        FaultKind.KILL: chosen,
        FaultKind.HANG: chosen,
        FaultKind.BLACKOUT: by(ComponentKind.BUS),
        FaultKind.BROKER: by(ComponentKind.BROKER),
        FaultKind.LINK: by(*SIMULATORS),
        FaultKind.FORKSERVER: [FORKSERVER] if config.supervisor.launcher == "fork" else [],
        FaultKind.DISK_FULL: by(ComponentKind.RCL),
        **{kind: sorted(r for r, link in relayed.items()
                        if link == "mavlink" or kind in TCP_KINDS)
           for kind in IMPAIRMENTS},
        **{kind: nodes for kind in NODE_KINDS},
        FaultKind.ROBOT_LOSS: sorted(relayed),
    }


# On TCP (MQTT) a `loss` is what TCP shows above it: stalls and reset connections
# (mrss.chaos.relay); it reorders nothing.
TCP_KINDS = (FaultKind.DELAY, FaultKind.PARTITION, FaultKind.LOSS)


def unavailable(config: ProjectConfig) -> dict[FaultKind, str]:
    """Why each kind with no target in this project has none (the report says it)."""
    relayed = relayed_robots(config)
    why: dict[FaultKind, str] = {}
    for kind in IMPAIRMENTS:
        if not any(link == "mavlink" or kind in TCP_KINDS for link in relayed.values()):
            why[kind] = ("no simulated robot whose link MRSS finds itself (a relay is put "
                         "in such a link's path)" if not relayed else
                         f"{kind} applies to MAVLink (UDP) links only; this project's "
                         "relayed links are MQTT (TCP)")
    for kind in NODE_KINDS:
        why[kind] = why_no_nodes(config) or "the project has a single node"
    if not relayed:
        why[FaultKind.ROBOT_LOSS] = ("no simulated robot whose link MRSS finds itself (a "
                                     "relay is put in such a link's path)")
    if config.supervisor.launcher != "fork":
        why[FaultKind.FORKSERVER] = "the supervisor's launcher is not fork"
    return why


def home_node(config: ProjectConfig) -> str:
    """The node a campaign records from (its RCL's: the journal and the bus it hears);
    "" for a project on one host."""
    plan = node_plan(config)
    if not plan.nodes:
        return ""
    rcl = next(iter(config.of_kind(ComponentKind.RCL)), None)
    return (plan.placement.get(rcl.id) if rcl is not None else None) or sorted(plan.nodes)[0]


def why_no_nodes(config: ProjectConfig) -> str:
    """Why a campaign cannot run this project's nodes in namespaces and cut them apart
    ("" when it can)."""
    plan = node_plan(config)
    if not plan.nodes:
        return "the project runs on one host (no [nodes])"
    return why_no_netns(plan.nodes) or why_no_nft()


def components_of(config: ProjectConfig, kind: ComponentKind) -> list[str]:
    return [c.id for c in config.of_kind(kind)]


class Injector:
    """Injects faults into the process tree of one root supervisor."""

    def __init__(self, root_pid: int, pid_of: Callable[[str], int | None],
                 relays: Relays | None = None, network: NodeNetwork | None = None) -> None:
        self.root_pid = root_pid
        self.pid_of = pid_of
        self.relays = relays
        self.network = network
        # (pid, effect) -> how many timed faults hold it now, and how to undo it (the
        # first fault's heal), run by the heal that brings the count back to 0.
        self._holding: dict[tuple[int, Effect], tuple[int, Heal]] = {}

    def inject(self, fault: Fault) -> tuple[int, Heal | None]:
        """Inject `fault` now; the pid hit and, for a timed fault, how to heal it."""
        kind = fault.kind
        if kind is FaultKind.ROBOT_LOSS:  # a partition never healed
            if self.relays is None:
                raise InjectionError(f"{fault.target}: no relay in the path (the campaign "
                                     "started none)")
            try:
                self.relays.impair(fault.target, Impairment.PARTITION, 0.0)
            except NetworkError as exc:
                raise InjectionError(str(exc)) from None
            return 0, None
        if kind in IMPAIRMENTS:
            if self.relays is None:
                raise InjectionError(f"{fault.target}: no relay in the path (the campaign "
                                     "started none)")
            try:
                return 0, self.relays.impair(fault.target, IMPAIRMENTS[kind], fault.amount)
            except NetworkError as exc:
                raise InjectionError(str(exc)) from None
        if kind in NODE_KINDS:
            if self.network is None:
                raise InjectionError(f"{kind}: the campaign runs no node network")
            try:
                if kind is FaultKind.NODE_DELAY:
                    return 0, self.network.delay(fault.target, fault.amount)
                return 0, self.network.cut(fault.target, int(fault.amount))
            except NetworkError as exc:
                raise InjectionError(str(exc)) from None
        if kind is FaultKind.FORKSERVER:
            pid = self._forkserver()
            self._signal(pid, signal.SIGKILL)
            return pid, None
        pid = self._component(fault.target)
        if kind in (FaultKind.KILL, FaultKind.BROKER):
            self._signal(pid, signal.SIGKILL)
            return pid, None
        if kind in (FaultKind.HANG, FaultKind.BLACKOUT, FaultKind.LINK):
            return pid, self._hold(pid, Effect.STOPPED, self._stop)
        if kind is FaultKind.DISK_FULL:
            return pid, self._hold(pid, Effect.DISK_FULL, self._fill_disk)
        raise InjectionError(f"unknown fault kind {kind!r}")

    def _hold(self, pid: int, effect: Effect, start: Callable[[int], Heal]) -> Heal:
        """One more fault holds `effect` on `pid`: the first starts it (`start(pid)`,
        which returns how to undo it), the last one healed undoes it. Each heal counts
        once."""
        key = (pid, effect)
        count, undo = self._holding.get(key) or (0, None)
        self._holding[key] = (count + 1, undo or start(pid))
        healed = False

        def heal() -> None:
            nonlocal healed
            if healed:
                return
            healed = True
            left, undo = self._holding.pop(key)
            if left > 1:
                self._holding[key] = (left - 1, undo)
            else:
                undo()
        return heal

    def _stop(self, pid: int) -> Heal:
        self._signal(pid, signal.SIGSTOP)
        return lambda: _resume(pid)

    def _component(self, name: str) -> int:
        pid = self.pid_of(name)
        if not pid:
            raise InjectionError(f"{name}: no known pid (not running?)")
        if pid not in self._tree():
            raise InjectionError(f"{name}: pid {pid} is not in the system's process tree "
                                 "(it restarted meanwhile)")
        return pid

    def _forkserver(self) -> int:
        try:
            children = psutil.Process(self.root_pid).children()
        except psutil.NoSuchProcess:
            raise InjectionError("the root supervisor is gone") from None
        for child in children:
            try:
                if is_fork_server(child.cmdline(), child.name()):
                    return int(child.pid)
            except psutil.Error:
                continue
        raise InjectionError("the root supervisor has no fork server (exec launcher?)")

    def _tree(self) -> set[int]:
        try:
            return {p.pid for p in psutil.Process(self.root_pid).children(recursive=True)}
        except psutil.NoSuchProcess:
            return set()

    def _signal(self, pid: int, sig: int) -> None:
        try:
            os.kill(pid, sig)
        except ProcessLookupError:
            raise InjectionError(f"pid {pid} is gone") from None

    def _fill_disk(self, pid: int) -> Heal:
        if not sigxfsz_ignored(pid):
            raise InjectionError(f"pid {pid} does not ignore SIGXFSZ: a file size limit "
                                 "would kill it instead of failing its writes")
        process = psutil.Process(pid)
        soft, hard = process.rlimit(psutil.RLIMIT_FSIZE)
        process.rlimit(psutil.RLIMIT_FSIZE, (0, hard))

        def heal() -> None:
            try:
                process.rlimit(psutil.RLIMIT_FSIZE, (soft, hard))
            except psutil.NoSuchProcess:
                pass
        return heal


def _resume(pid: int) -> None:
    try:
        os.kill(pid, signal.SIGCONT)
    except ProcessLookupError:
        pass  # killed meanwhile (a hang found by its supervisor): nothing to heal


def sigxfsz_ignored(pid: int) -> bool:
    """Whether the process ignores SIGXFSZ (from /proc/<pid>/status)."""
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("SigIgn:"):
                return bool(int(line.split()[1], 16) & SIGXFSZ_BIT)
    except (OSError, ValueError):
        return False
    return False
