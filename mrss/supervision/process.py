"""The root supervisor: component processes under the shared RestartPolicy.

One idea in one module, on purpose (~480 lines): the loop owns every child's state and
is the only writer of it, so starting, watching, stopping and deciding read as one
sequence; the rules it applies live elsewhere (policy.py, child_states.py, children.py).

One thread runs the loop and owns all child state; other threads (signal handlers, the
TUI, tests) submit commands and read snapshots. The loop starts children one at a time
in order and waits for each to report ready; detects exits (any reason, SIGKILL
included), start timeouts and hangs (missed heartbeats); stops children in reverse
order, SIGTERM first and SIGKILL when their shutdown time is up; and applies the
policy's decisions. A component (or group) over its budget is given up: with
`on_exceeded = quarantine` (config: `on_give_up = "stop_component"`) only it is stopped,
`sup.give_up` goes out and it is retried after `probation`; with `escalate`
(`"stop_system"`) everything stops and the loop ends with an `Outcome` naming the child
and its last reason. A lost fork server is one launcher restart (`sup.restart` of
`forkserver`): the children it forked keep running.
"""

from __future__ import annotations

import logging
import math
import os
import random
import signal
import threading
import time
from collections.abc import Callable, Iterable
from typing import Any

from mrss.errors import SupervisionError
from mrss.supervision import control
from mrss.supervision import events as ev
from mrss.supervision.child_states import ChildCause, move
from mrss.supervision.children import ComponentStart, Proc, ProcessSettings
from mrss.supervision.events import Publish, SupEvents
from mrss.supervision.launchers import ExecLauncher, ForkLauncher, Launcher, preload_modules
from mrss.supervision.loop import EventLoop
from mrss.supervision.policy import Action, Decision, RestartPolicy
from mrss.supervision.reason import Cause, ExitReason
from mrss.supervision.spec import ChildKind, ChildSpec, Strategy, SupervisorSpec
from mrss.supervision.start import StartContext
from mrss.supervision.status import ChildState, ChildStatus, Outcome

log = logging.getLogger("mrss.supervision.process")

FORK_SERVER = "forkserver"  # the child name of the fork server in sup.* events


class ProcessSupervisor:
    """Runs component processes per their ChildSpecs; see the module docstring."""

    def __init__(
        self, name: str, spec: SupervisorSpec, children: Iterable[ChildSpec[ComponentStart]],
        settings: ProcessSettings, *, publish: Publish | None = None,
        clock: Callable[[], float] = time.monotonic, rand: Callable[[], float] = random.random,
        node: str | None = None, fork_server: ForkLauncher | None = None,
    ) -> None:
        """`fork_server`: a launcher made `ForkLauncher.early` for these children (the
        fork launcher only), taken over when the supervisor runs."""
        self.name = name
        self.spec = spec
        self.settings = settings
        self.events = SupEvents(name, publish, node=node)
        self._clock = clock
        self._procs: dict[str, Proc] = {}
        for child in children:
            if not isinstance(child.start, ComponentStart):
                raise SupervisionError(f"child {child.id}: start must be a ComponentStart")
            self._procs[child.id] = Proc(child)
        self._policy = RestartPolicy(spec, (p.spec for p in self._procs.values()),
                                     clock=clock, rand=rand)
        self._lock = threading.RLock()
        self._loop = EventLoop()
        self._launcher: Launcher | None = None
        self._early = fork_server
        self._by_pid: dict[int, Proc] = {}
        self._stop_queue: list[str] = []
        self._finishing: Outcome | None = None
        self._outcome: Outcome | None = None
        self._initial_done = False
        self._started = threading.Event()
        self._done = threading.Event()
        self._pings: dict[str, threading.Event] = {}
        self._ping_seq = 0
        self._thread: threading.Thread | None = None

    # -- running ---------------------------------------------------------------------------
    def run(self) -> Outcome:
        """Run the loop in this thread until stopped or given up."""
        try:
            self._launcher = self._make_launcher()
            while self._outcome is None:
                self._step()
        except Exception as exc:
            log.exception("root supervisor %s failed", self.name)
            self._outcome = Outcome(True, "", f"supervisor error: {exc}", "")
        finally:
            self._cleanup()
            self._started.set()
            self._done.set()
        return self._outcome

    def start(self) -> None:
        """Run the loop on a background thread (tests, benchmarks, embedding)."""
        self._thread = threading.Thread(target=self.run, name=f"sup-{self.name}", daemon=True)
        self._thread.start()

    def wait_started(self, timeout: float = 30.0) -> bool:
        """Wait until every child was started once (or the supervisor ended)."""
        return self._started.wait(timeout)

    def wait(self, timeout: float | None = None) -> Outcome | None:
        """Wait for the loop to end; its outcome, or None on timeout."""
        self._done.wait(timeout)
        return self._outcome

    def request_stop(self, force: bool = False) -> None:
        """Stop every child in reverse order, then end the loop (safe in signal handlers).

        With `force` (a second Ctrl-C) every child still alive is killed at once.
        """
        self._loop.submit(self._kill_all if force else self._begin_shutdown)

    def stop(self, timeout: float | None = 60.0) -> Outcome | None:
        self.request_stop()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout)
        return self._outcome

    @property
    def outcome(self) -> Outcome | None:
        return self._outcome

    # -- queries and faults (any thread) ----------------------------------------------------
    def tree(self) -> ChildStatus:
        """The live tree: this supervisor and its component children, as plain data."""
        with self._lock:
            now = self._clock()
            kids = tuple(ChildStatus(
                id=p.id, kind=p.spec.kind.value, state=p.state.value,
                pid=p.pid if p.alive else 0, incarnation=p.incarnation,
                restarts=self._policy.restarts(p.id), budget=self._policy.budget(p.id, now),
                uptime=now - p.up_since if p.state is ChildState.RUNNING else 0.0,
                last_reason=p.last_reason) for p in self._procs.values())
            state = "stopped" if self._outcome else \
                "stopping" if self._finishing else "running"
            return ChildStatus(id=self.name, kind=ChildKind.SUPERVISOR.value, state=state,
                               pid=os.getpid(), strategy=self.spec.strategy.value,
                               children=kids)

    def pid_of(self, child: str) -> int:
        """The pid of the child's current incarnation if it is running, else 0."""
        with self._lock:
            p = self._get(child)
            return p.pid if p.state is ChildState.RUNNING else 0

    def ping(self, child: str, timeout: float = 1.0) -> bool:
        """Round trip over the child's control channel; True if its process answered."""
        done = threading.Event()
        with self._lock:
            self._ping_seq += 1
            token = str(self._ping_seq)
            self._pings[token] = done

        def send() -> None:
            p = self._procs.get(child)
            if p is not None and p.state is ChildState.RUNNING and p.sock is not None:
                control.send(p.sock, control.PING, token)

        self._loop.submit(send)
        ok = done.wait(timeout)
        with self._lock:
            self._pings.pop(token, None)
        return ok

    def crash(self, child: str) -> None:
        """Fault: make the child's process fail as if its code raised."""
        def send() -> None:
            p = self._procs.get(child)
            if p is not None and p.sock is not None and p.alive:
                control.send(p.sock, control.CRASH)
        self._get(child)
        self._loop.submit(send)

    def set_faults(self, child: str, **faults: object) -> None:
        """Faults for the child's next incarnation only (e.g. slow_start=seconds)."""
        with self._lock:
            self._get(child).faults.update(faults)

    # -- the loop ----------------------------------------------------------------------------
    def _step(self) -> None:
        timeout = self._next_deadline(self._clock())
        ready = self._loop.wait(timeout)
        with self._lock:
            for callback in ready:
                callback()
            assert self._launcher is not None
            self._launcher.flush()
            now = self._clock()
            self._timers(now)
            self._advance(now)

    def _make_launcher(self) -> Launcher:
        if self.settings.launcher == "exec":
            return ExecLauncher(self._loop.selector, self._on_exit)
        if self._early is not None:
            launcher, self._early = self._early, None
            launcher.attach(self._loop.selector, self._on_exit, self._fork_server_lost)
        else:
            modules = preload_modules(p.spec.start.target for p in self._procs.values())
            launcher = ForkLauncher(self._loop.selector, self._on_exit, preload=modules,
                                    path=[self.settings.project_dir],
                                    on_server_lost=self._fork_server_lost)
        launcher.start()
        return launcher

    def _fork_server_lost(self, why: str, kept: int) -> None:
        assert isinstance(self._launcher, ForkLauncher)
        launcher = self._launcher
        self.events.emit(ev.RESTART, FORK_SERVER, reason=f"killed: {why}",
                         count=launcher.servers_lost, kept=kept)
        if launcher.server_pid:
            self.events.emit(ev.START, FORK_SERVER, pid=launcher.server_pid)

    def _next_deadline(self, now: float) -> float:
        limit = self.settings.heartbeat_interval * self.settings.heartbeat_misses
        times = [now + 1.0, *(p.deadline(limit) for p in self._procs.values()
                              if p.state is not ChildState.WAITING)]
        times += [p.not_before for p in self._next_to_start()]
        return max(0.0, min(times) - now)

    def _next_to_start(self) -> list[Proc]:
        """The waiting children `_advance` may start next, so their start times matter.

        None while a child starts or stops: its ready message or exit wakes the loop, and
        a due start time would only make the loop spin until then.
        """
        procs = self._procs.values()
        if any(p.state in (ChildState.STARTING, ChildState.STOPPING) for p in procs):
            return []
        waiting = [p for p in procs if p.state is ChildState.WAITING]
        in_order = self.spec.strategy is not Strategy.ONE_FOR_ONE or not self._initial_done
        return waiting[:1] if in_order else waiting

    def _timers(self, now: float) -> None:
        interval, misses = self.settings.heartbeat_interval, self.settings.heartbeat_misses
        for p in self._procs.values():
            if p.state is ChildState.STARTING and not p.killed \
                    and now >= p.spawned_at + p.start_limit:
                p.verdict = ExitReason(Cause.START_TIMEOUT, f"not ready within "
                                       f"{p.start_limit:g}s")
                p.start_timeouts += 1  # the next start may take twice as long
                p.signal(signal.SIGKILL)
            elif p.state is ChildState.RUNNING and not p.killed \
                    and now - p.last_beat >= interval * misses:
                p.verdict = ExitReason(Cause.HUNG, f"no heartbeat for {now - p.last_beat:.2f}s "
                                       f"({misses} intervals of {interval:g}s)")
                self.events.emit(ev.HANG, p.id, pid=p.pid, reason=str(p.verdict))
                p.signal(signal.SIGKILL)
            elif p.state is ChildState.STOPPING and p.kill_at is not None and now >= p.kill_at:
                p.kill_at = None
                p.verdict = ExitReason(Cause.SHUTDOWN,
                                       f"killed after shutdown {p.spec.shutdown_timeout:g}s")
                p.signal(signal.SIGKILL)
            elif p.state is ChildState.QUARANTINED and now >= p.not_before \
                    and self._finishing is None:
                self._policy.release(p.id)
                self.events.emit(ev.RELEASE, p.id)
                p.state = move(p.state, ChildCause.PROBATION_OVER, p.id)

    def _advance(self, now: float) -> None:
        """Stop what must stop (one at a time, in order), then start the next child."""
        if any(p.state is ChildState.STOPPING for p in self._procs.values()):
            return
        while self._stop_queue:
            p = self._procs[self._stop_queue.pop(0)]
            if p.alive:
                self._begin_stop(p, now)
                return
        if self._finishing is not None:
            if not any(p.alive for p in self._procs.values()):
                self._outcome = self._finishing
            return
        if any(p.state is ChildState.STARTING for p in self._procs.values()):
            return
        waiting = [p for p in self._procs.values() if p.state is ChildState.WAITING]
        if not waiting:
            self._initial_done = True
            self._started.set()
            return
        in_order = self.spec.strategy is not Strategy.ONE_FOR_ONE or not self._initial_done
        for p in waiting[:1] if in_order else waiting:
            if p.not_before <= now:
                self._spawn(p, now)
                return

    # -- starting ----------------------------------------------------------------------------
    def _spawn(self, p: Proc, now: float) -> None:
        assert self._launcher is not None
        p.incarnation += 1
        p.killed, p.verdict, p.told, p.kill_at = False, None, "", None
        ctx = StartContext(
            name=p.id, incarnation=p.incarnation, project_dir=self.settings.project_dir,
            run_dir=self.settings.run_dir, bus=self.settings.bus,
            options=p.spec.start.options, heartbeat_interval=self.settings.heartbeat_interval,
            faults=p.faults, scheduling=p.spec.start.scheduling.to_dict())
        p.faults = {}
        ours, theirs = control.socket_pair()
        try:
            pid = self._launcher.spawn(p.spec.start.target, p.id, p.incarnation, ctx.to_json(),
                                       theirs)
        except SupervisionError as exc:
            ours.close()
            p.state, p.spawned_at = move(p.state, ChildCause.STARTED, p.id), now
            self._failed(p, ExitReason(Cause.CRASHED, str(exc)))
            return
        finally:
            theirs.close()
        ours.setblocking(False)
        p.sock, p.pid, p.spawned_at = ours, pid, now
        p.state = move(p.state, ChildCause.STARTED, p.id)
        try:
            p.pidfd = os.pidfd_open(pid)
        except OSError:
            p.pidfd = -1  # already gone: its exit report is on the way
        self._by_pid[pid] = p
        inc = p.incarnation
        self._loop.register(ours, lambda: self._on_control(p, inc))

    def _on_control(self, p: Proc, inc: int) -> None:
        if p.incarnation != inc or p.sock is None:
            return
        while True:
            try:
                packet = p.sock.recv(control.MAX_PACKET)
            except BlockingIOError:
                return
            except OSError:
                packet = b""
            if not packet:  # its end closed: the exit report follows
                self._loop.unregister(p.sock)
                p.sock.close()
                p.sock = None
                return
            self._on_message(p, *control.decode(packet))

    def _on_message(self, p: Proc, kind: str, text: str) -> None:
        now = self._clock()
        if kind == control.HEARTBEAT:
            p.last_beat = now
        elif kind == control.READY and p.state is ChildState.STARTING:
            p.state, p.up_since, p.last_beat = move(p.state, ChildCause.READY, p.id), now, now
            p.start_timeouts = 0
            self._policy.child_started(p.id)
            key = self.settings.key  # the proof of the new incarnation, for receivers
            proof: dict[str, Any] = \
                {"cred": key.credential(p.id, p.incarnation).hex()} if key else {}
            self.events.emit(ev.START, p.id, pid=p.pid, inc=p.incarnation,
                             startup_ms=round((now - p.spawned_at) * 1000, 1), **proof)
        elif kind == control.FAIL:
            p.told = text
        elif kind == control.PONG:
            done = self._pings.get(text)
            if done is not None:
                done.set()

    # -- stopping and exits ------------------------------------------------------------------
    def _begin_stop(self, p: Proc, now: float) -> None:
        p.state = move(p.state, ChildCause.STOP_ASKED, p.id)
        if p.spec.shutdown_timeout <= 0:
            p.verdict = ExitReason(Cause.SHUTDOWN, "killed (shutdown = kill)")
            p.signal(signal.SIGKILL)
        else:
            p.kill_at = now + p.spec.shutdown_timeout
            p.signal(signal.SIGTERM)

    def _on_exit(self, pid: int, status: ExitReason) -> None:
        with self._lock:
            p = self._by_pid.pop(pid, None)
            if p is None or p.pid != pid or not p.alive:
                return
            if p.sock is not None:
                self._on_control(p, p.incarnation)  # read its last words ("fail ...")
            if p.sock is not None:
                self._loop.unregister(p.sock)
            p.close()
            if p.state is ChildState.STOPPING:
                self._stopped(p, status)
            else:
                self._failed(p, p.exit_reason(status))

    def _stopped(self, p: Proc, status: ExitReason) -> None:
        if p.verdict is not None:
            reason = p.verdict
        elif status.cause is Cause.NORMAL:
            reason = ExitReason(Cause.SHUTDOWN, "stopped by supervisor")
        else:
            reason = ExitReason(Cause.SHUTDOWN, f"stopped by supervisor ({status})")
        p.last_reason = str(reason)
        self._policy.child_stopped(p.id)
        self.events.emit(ev.EXIT, p.id, pid=p.pid, reason=str(reason), inc=p.incarnation)
        if self._finishing is None and p.then_restart:
            p.state = move(p.state, ChildCause.STOPPED_TO_RESTART, p.id)
        elif self._finishing is None and p.then_quarantine:
            p.state = move(p.state, ChildCause.STOPPED_TO_QUARANTINE, p.id)
        else:
            p.state = move(p.state, ChildCause.STOPPED, p.id)
        p.then_restart = p.then_quarantine = False

    def _failed(self, p: Proc, reason: ExitReason) -> None:
        p.last_reason = str(reason)
        self.events.emit(ev.EXIT, p.id, pid=p.pid, reason=str(reason), inc=p.incarnation)
        p.state = move(p.state, ChildCause.EXITED, p.id)
        if self._finishing is not None:
            return
        running = {q.id for q in self._procs.values() if q.alive}
        self._apply(self._policy.child_exited(p.id, reason, running=running))

    def _apply(self, d: Decision) -> None:
        now = self._clock()
        if d.action is Action.RESTART:
            for sid in d.stop:
                self._procs[sid].then_restart = sid in d.restart
                self._stop_queue.append(sid)
            for rid in d.restart:
                q = self._procs[rid]
                q.not_before = now + d.delay
                if not q.alive:
                    q.state = move(q.state, ChildCause.RESTART_DUE, q.id)
            extra: dict[str, Any] = {"subtree": d.group, "note": d.note} if d.group else {}
            self.events.emit(ev.RESTART, d.child, reason=str(d.reason), count=d.count,
                             delay=round(d.delay, 3), group=list(d.restart), **extra)
        elif d.action is Action.QUARANTINE:
            self._give_up_component(d, now)
        elif d.action is Action.ESCALATE:
            self.events.emit(ev.GIVE_UP, d.child, reason=str(d.reason), note=d.note,
                             stops="system")
            self._finish(Outcome(True, d.child, str(d.reason), d.note))

    def _give_up_component(self, d: Decision, now: float) -> None:
        """Stop only the culprit (the child, or its group) and retry it after probation."""
        retry = now + d.delay if math.isfinite(d.delay) else math.inf
        for cid in d.drop:
            q = self._procs[cid]
            q.not_before = retry
            if cid in d.stop:
                q.then_quarantine = True
                self._stop_queue.append(cid)
            elif not q.alive:
                q.state = move(q.state, ChildCause.GIVEN_UP, q.id)
        self.events.emit(
            ev.GIVE_UP, d.child, reason=str(d.reason), count=d.count, note=d.note,
            stops="component", subtree=d.group, members=list(d.drop),
            retry_in=round(d.delay, 3) if math.isfinite(d.delay) else None)

    def _begin_shutdown(self) -> None:
        if self._finishing is None:
            log.info("%s: stopping every child in reverse order", self.name)
            # said while the bus still runs: a dashboard knows the silence that follows
            self.events.emit(ev.STOPPING, self.name, reason="asked to stop")
            self._finish(Outcome(False))

    def _kill_all(self) -> None:
        self._begin_shutdown()
        for p in self._procs.values():
            if p.alive and not p.killed:
                p.state = move(p.state, ChildCause.STOP_ASKED, p.id)
                p.verdict = ExitReason(Cause.SHUTDOWN, "killed (forced stop)")
                p.signal(signal.SIGKILL)

    def _finish(self, outcome: Outcome) -> None:
        self._finishing = outcome
        for p in self._procs.values():
            p.then_restart = p.then_quarantine = False
            if p.state in (ChildState.WAITING, ChildState.QUARANTINED):
                p.state = move(p.state, ChildCause.STOP_ASKED, p.id)
        self._stop_queue = [p.id for p in reversed(self._procs.values()) if p.alive]

    def _cleanup(self) -> None:
        with self._lock:
            for p in self._procs.values():
                if p.alive:
                    p.signal(signal.SIGKILL)
                    p.state = move(p.state, ChildCause.ABANDONED, p.id)
                p.close()
            if self._launcher is not None:
                self._launcher.close()
            if self._early is not None:  # never taken over
                self._early.close()
                self._early = None
        self._loop.close()

    def _get(self, child: str) -> Proc:
        try:
            return self._procs[child]
        except KeyError:
            raise SupervisionError(f"{self.name} has no child {child!r}") from None
