"""What the root supervisor keeps for each component process, and how it reaches it."""

from __future__ import annotations

import os
import signal
import socket
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from mrss.messages import IncarnationKey
from mrss.supervision.reason import Cause, ExitReason
from mrss.supervision.spec import ChildSpec
from mrss.supervision.status import ChildState


@dataclass(frozen=True)
class Scheduling:
    """A component process's CPU scheduling (project.toml `nice`, `cpus`; None: inherited).

    Applied by the component process itself before it starts (`mrss.supervision.
    scheduling`), so every thread it makes inherits it.
    """

    nice: int | None = None
    cpus: tuple[int, ...] | None = None
    realtime: int | None = None  # SCHED_RR priority 1..99

    def to_dict(self) -> dict[str, Any]:
        return {"nice": self.nice, "cpus": None if self.cpus is None else list(self.cpus),
                "realtime": self.realtime}


@dataclass(frozen=True)
class ComponentStart:
    """How to start a component process: its class, options, start time limit, scheduling."""

    target: str  # "dotted.module:Class"
    options: dict[str, Any] = field(default_factory=dict)
    start_timeout: float = 10.0
    scheduling: Scheduling = field(default_factory=Scheduling)

    @property
    def module(self) -> str:
        return self.target.partition(":")[0]


@dataclass(frozen=True)
class ProcessSettings:
    """Where components run and how closely they are watched."""

    project_dir: Path
    run_dir: Path
    bus: dict[str, Any] = field(default_factory=dict)
    heartbeat_interval: float = 0.5
    heartbeat_misses: int = 3
    launcher: Literal["fork", "exec"] = "fork"
    # The run's incarnation key: each `sup.start` carries the started incarnation's
    # credential (mrss/messages/credentials.py); None: a bus without one.
    key: IncarnationKey | None = None


START_PATIENCE_MAX = 8  # a start may take at most 8 x start_timeout after slow ones


@dataclass
class Proc:
    """One component child: its spec and the state of its current incarnation."""

    spec: ChildSpec[ComponentStart]
    state: ChildState = ChildState.WAITING
    incarnation: int = 0
    pid: int = 0
    pidfd: int = -1
    sock: socket.socket | None = None
    spawned_at: float = 0.0
    up_since: float = 0.0
    last_beat: float = 0.0
    not_before: float = 0.0  # WAITING: earliest start; QUARANTINED: release time
    kill_at: float | None = None  # STOPPING: when the shutdown time is up
    killed: bool = False
    verdict: ExitReason | None = None  # why we killed it, overriding the wait status
    told: str = ""  # the reason the child reported before exiting
    then_restart: bool = False  # STOPPING: start again after the exit
    then_quarantine: bool = False  # STOPPING: its group was given up; stays down after
    last_reason: str = ""
    faults: dict[str, Any] = field(default_factory=dict)  # for the next incarnation only
    start_timeouts: int = 0  # consecutive starts killed as not ready in time

    @property
    def start_limit(self) -> float:
        """How long this start may take: the spec's `start_timeout`, doubled after each
        start in a row that took longer (a slow or loaded host, a first run that
        compiles or migrates), at most START_PATIENCE_MAX times it; a start that
        reaches ready resets it."""
        return self.spec.start.start_timeout * min(1 << min(self.start_timeouts, 8),
                                                    START_PATIENCE_MAX)

    @property
    def id(self) -> str:
        return self.spec.id

    @property
    def alive(self) -> bool:
        return self.state in (ChildState.STARTING, ChildState.RUNNING, ChildState.STOPPING)

    def deadline(self, heartbeat_limit: float) -> float:
        """When this child next needs the loop's attention (inf if it does not)."""
        if self.state is ChildState.STARTING and not self.killed:
            return self.spawned_at + self.start_limit
        if self.state is ChildState.RUNNING and not self.killed:
            return self.last_beat + heartbeat_limit
        if self.state is ChildState.STOPPING and self.kill_at is not None:
            return self.kill_at
        if self.state in (ChildState.WAITING, ChildState.QUARANTINED):
            return self.not_before
        return float("inf")

    def signal(self, sig: int) -> None:
        """Signal the incarnation; SIGKILL takes its whole process group with it."""
        if sig == signal.SIGKILL:
            self.killed = True
            try:
                os.killpg(self.pid, sig)
                return
            except (ProcessLookupError, PermissionError):
                pass
        try:
            if self.pidfd >= 0:
                signal.pidfd_send_signal(self.pidfd, sig)
            elif self.pid:
                os.kill(self.pid, sig)
        except ProcessLookupError:
            pass

    def exit_reason(self, status: ExitReason) -> ExitReason:
        """The best account of an unexpected exit: our verdict, the child's word, or status."""
        if self.verdict is not None:
            return self.verdict
        if self.told:
            cause, _, detail = self.told.partition(": ")
            try:
                return ExitReason(Cause(cause), detail)
            except ValueError:
                return ExitReason(Cause.CRASHED, self.told)
        if self.state is ChildState.STARTING:
            return ExitReason(status.cause, f"{status.detail} during start")
        return status

    def close(self) -> None:
        """Forget the incarnation's channel and pid descriptor."""
        if self.sock is not None:
            self.sock.close()
            self.sock = None
        if self.pidfd >= 0:
            os.close(self.pidfd)
            self.pidfd = -1
