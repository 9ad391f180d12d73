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

from mrss.config.kinds import ComponentKind
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

    @property
    def timed(self) -> bool:
        """Whether the fault lasts (and is healed) rather than happening once."""
        return self in (FaultKind.HANG, FaultKind.BLACKOUT, FaultKind.LINK,
                        FaultKind.DISK_FULL)


class InjectionError(MrssError):
    """A fault could not be injected (no such process, not allowed)."""


@dataclass(frozen=True)
class Fault:
    """One planned fault: when (s after the faults begin), what, on whom, how long."""

    at: float
    kind: FaultKind
    target: str
    duration: float = 0.0


Heal = Callable[[], None]


class Effect(StrEnum):
    """What a timed fault does to a process, which overlapping faults share."""

    STOPPED = "stopped"      # SIGSTOP until SIGCONT: hang, blackout, link
    DISK_FULL = "disk_full"  # RLIMIT_FSIZE 0 until the saved limit is back


def targets(config: ProjectConfig, only: Iterable[str] = ()) -> dict[FaultKind, list[str]]:
    """The possible targets of each fault kind in this project (empty list: not possible).

    `only` limits `kill` and `hang` to those components (targeted campaigns).
    """
    enabled = [c for c in config.components if c.enabled]
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
    }


def components_of(config: ProjectConfig, kind: ComponentKind) -> list[str]:
    return [c.id for c in config.of_kind(kind)]


class Injector:
    """Injects faults into the process tree of one root supervisor."""

    def __init__(self, root_pid: int, pid_of: Callable[[str], int | None]) -> None:
        self.root_pid = root_pid
        self.pid_of = pid_of
        # (pid, effect) -> how many timed faults hold it now, and how to undo it (the
        # first fault's heal), run by the heal that brings the count back to 0.
        self._holding: dict[tuple[int, Effect], tuple[int, Heal]] = {}

    def inject(self, fault: Fault) -> tuple[int, Heal | None]:
        """Inject `fault` now; the pid hit and, for a timed fault, how to heal it."""
        kind = fault.kind
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
