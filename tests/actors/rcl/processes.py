"""What the RCL's process tests share: child processes killed at the end, a run
directory, a bus proxy with a listener that plays the reasoner, and the root supervisor
over the RCL component (and simulators) of a test project."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from mrss.bus import BusEndpoints, Publisher, ReliableSender, Subscriber
from mrss.config.kinds import KINDS, ComponentKind
from mrss.messages import (
    ActionStatus,
    AllocationState,
    Envelope,
    RobotState,
    TaskAllocation,
)
from mrss.supervision import (
    Backoff,
    ChildSpec,
    ComponentStart,
    EventLog,
    ProcessSettings,
    ProcessSupervisor,
    SupervisorSpec,
)
from mrss.testing import wait_until


class Procs:
    """Child processes of a test, all killed at the end."""

    def __init__(self) -> None:
        self.all: list[subprocess.Popen[str]] = []

    def start(self, *args: str) -> subprocess.Popen[str]:
        proc = subprocess.Popen([sys.executable, "-m", *args], stdout=subprocess.PIPE,
                                stderr=subprocess.DEVNULL, text=True, env=os.environ.copy())
        self.all.append(proc)
        line = proc.stdout.readline() if proc.stdout else ""
        assert line.startswith("ready"), f"{args[0]} did not start: {line!r}"
        return proc

    def close(self) -> None:
        for proc in self.all:
            if proc.poll() is None:
                proc.kill()
            proc.wait(timeout=10)
            if proc.stdout:
                proc.stdout.close()


def rcl_child(options: dict[str, Any]) -> ChildSpec:
    """The RCL component (named `rcl`, so its journal is `rcl-journal.sqlite3`)."""
    return ChildSpec("rcl", ComponentStart(KINDS[ComponentKind.RCL].target, options, 20.0),
                     shutdown=5.0)


def uav_sim_child(robot: str, home: Sequence[float]) -> ChildSpec:
    """A simulated UAV (`mrss sim uav`) speaking MAVLink over UDP."""
    return ChildSpec(robot, ComponentStart(KINDS[ComponentKind.SIM_UAV].target,
                                           {"id": robot, "home": list(home)}, 20.0),
                     shutdown=5.0)


def root(project: Path, run_dir: Path, endpoints: BusEndpoints, children: list[ChildSpec], *,
         intensity: int = 3, heartbeat_misses: int = 20) -> ProcessSupervisor:
    """The root supervisor over `children` (restarting at once, no jitter)."""
    return ProcessSupervisor(
        "root", SupervisorSpec(intensity=intensity, period=30.0,
                               backoff=Backoff(initial=0.02, jitter=0.0)), children,
        ProcessSettings(project, run_dir, bus=endpoints.to_dict(), heartbeat_interval=0.1,
                        heartbeat_misses=heartbeat_misses),
        publish=EventLog())


class Bus:
    """A bus proxy process, a listener keeping what it heard, the reasoner's reliable
    action sender (`tx`, incarnation 1) and the operator's publisher (`pub`)."""

    def __init__(self, procs: Procs, run_dir: Path, prefixes: Sequence[str]) -> None:
        self.run_dir = run_dir
        self.endpoints = BusEndpoints.ipc(run_dir)
        procs.start("mrss.bus.proxy", "--run-dir", str(run_dir))
        self.seen: list[Envelope] = []
        self.sub = Subscriber(self.endpoints, prefixes=list(prefixes))
        self.sub.start(self.seen.append)
        assert self.sub.wait_connected(5)
        self.tx = ReliableSender(self.endpoints, src="reasoner", inc=1, channel="action")
        self.pub = Publisher(self.endpoints, src="operator", batching=False)

    def close(self) -> None:
        self.tx.close()
        self.pub.close()
        self.sub.close()

    def bodies(self, kind: type, **match: Any) -> list[Any]:
        """What was heard of `kind`, its fields equal to `match`, in order."""
        return [e.body for e in list(self.seen) if isinstance(e.body, kind)
                and all(getattr(e.body, k) == v for k, v in match.items())]

    def statuses(self, uuid: str) -> list[ActionStatus]:
        return self.bodies(ActionStatus, uuid=uuid)

    def allocations(self, uuid: str) -> list[TaskAllocation]:
        return self.bodies(TaskAllocation, uuid=uuid)

    def awards(self, uuid: str) -> list[TaskAllocation]:
        return [a for a in self.allocations(uuid) if a.state is AllocationState.AWARDED]

    def waiting(self, uuid: str) -> bool:
        return any(a.state is AllocationState.WAITING for a in self.allocations(uuid))

    def awarded(self, uuid: str, timeout: float = 20) -> TaskAllocation:
        """The first award of `uuid` (waited for)."""
        wait_until(lambda: bool(self.awards(uuid)), timeout=timeout, message=f"{uuid} awarded")
        return self.awards(uuid)[0]

    def ended(self, uuid: str, timeout: float = 30) -> ActionStatus:
        """The first terminal status of `uuid` (waited for)."""
        wait_until(lambda: any(s.state.terminal for s in self.statuses(uuid)),
                   timeout=timeout, message=f"{uuid} ended")
        return next(s for s in self.statuses(uuid) if s.state.terminal)

    def available(self, robot: str) -> bool:
        states = self.bodies(RobotState, robot=robot)
        return bool(states) and states[-1].available

    def journal(self) -> Path:
        return self.run_dir / "rcl-journal.sqlite3"
