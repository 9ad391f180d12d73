"""Fault injection: kill, hang, crash-in-handler and slow start, for tests and the TUI.

Process faults act on the current incarnation of a component under a ProcessSupervisor
with real signals (exactly what an outside killer would do); actor faults send the
fault messages a SupervisedActor understands. `inject` is the one entry point for a
fault named by a string (the TUI's `ctl.fault` command).
"""

from __future__ import annotations

import os
import signal
from typing import Any

import pykka

from mrss.errors import SupervisionError
from mrss.supervision.process import ProcessSupervisor
from mrss.supervision.supervised import BlockFor, CrashNow

PROCESS_FAULTS = ("kill", "term", "hang", "crash", "slow_start")
ACTOR_FAULTS = ("crash", "hang")


def _running_pid(sup: ProcessSupervisor, child: str) -> int:
    pid = sup.pid_of(child)
    if not pid:
        raise SupervisionError(f"{child} is not running; nothing to inject into")
    return pid


def kill(sup: ProcessSupervisor, child: str, sig: int = signal.SIGKILL) -> int:
    """Send `sig` (SIGKILL by default) to the child's process; returns the pid hit."""
    pid = _running_pid(sup, child)
    os.kill(pid, sig)
    return pid


def hang(sup: ProcessSupervisor, child: str) -> int:
    """SIGSTOP the child's process: it stops heartbeating and must be found hung."""
    return kill(sup, child, signal.SIGSTOP)


def crash(sup: ProcessSupervisor, child: str) -> int:
    """Make the child's process fail as its code would (reason `crashed: InjectedFault`)."""
    pid = _running_pid(sup, child)
    sup.crash(child)
    return pid


def slow_start(sup: ProcessSupervisor, child: str, seconds: float) -> None:
    """The child's next incarnation waits `seconds` before its start (e.g. past its timeout)."""
    sup.set_faults(child, slow_start=float(seconds))


def crash_actor(supervisor: pykka.ActorRef[Any], child: str, detail: str = "injected crash") \
        -> None:
    """Make the actor child's next handler raise (crash-in-handler)."""
    _actor(supervisor, child).tell(CrashNow(detail))


def hang_actor(supervisor: pykka.ActorRef[Any], child: str, seconds: float) -> None:
    """Block the actor child's next handler for `seconds` (its watchdog should fire)."""
    _actor(supervisor, child).tell(BlockFor(seconds))


def _actor(supervisor: pykka.ActorRef[Any], child: str) -> pykka.ActorRef[Any]:
    ref: pykka.ActorRef[Any] | None = supervisor.proxy().ref_of(child).get(timeout=5)
    if ref is None:
        raise SupervisionError(f"actor {child} is not running; nothing to inject into")
    return ref


def inject(sup: ProcessSupervisor, fault: str, child: str, **args: Any) -> None:
    """Inject a process fault named by a string: kill, term, hang, crash, slow_start."""
    if fault == "kill":
        kill(sup, child)
    elif fault == "term":
        kill(sup, child, signal.SIGTERM)
    elif fault == "hang":
        hang(sup, child)
    elif fault == "crash":
        crash(sup, child)
    elif fault == "slow_start":
        slow_start(sup, child, float(args.get("seconds", 5.0)))
        kill(sup, child)
    else:
        raise SupervisionError(f"unknown fault {fault!r}; known: {', '.join(PROCESS_FAULTS)}")
