"""Entry point of a component process: import the class, start it, report, heartbeat.

`python -m mrss.runtime.main module.path:Class --name ID --inc N
--context JSON [--control-fd FD]`. With a control channel the process reports `ready`
once `start` returns, heartbeats every interval while `healthy()`, answers pings, and
stops when the supervisor closes the channel (the supervisor died). SIGTERM or SIGINT
call `stop()` and exit 0. A failing start or stop, or `ctx.fail()`, reports the reason
and exits 1. Without --control-fd it runs standalone until SIGTERM/SIGINT.

Logging (`mrss.logs`): one line format on stderr; supervised, also appended to the run's
`<run_dir>/mrss.log`; with bus endpoints, records at INFO and above also go on the bus
as `LogRecord`s on `log.<name>` (bounded, never blocking the logging thread).

With bus endpoints a thread of its own (never the heartbeat's: a first publish may wait
for the bus) publishes the process's refusal counters when they move
(`mrss.edge.rejection_reports`: `Rejections` on `edge.rejections.<name>`), for the
dashboard: what its edge refused, and the messages the bus's incarnation rule refused.
"""

from __future__ import annotations

import argparse
import gc
import importlib
import json
import logging
import os
import signal
import socket
import sys
import threading
import time
import traceback
from collections.abc import Sequence
from types import FrameType
from typing import Any

from mrss import logs
from mrss.bus.incarnations import refusal_counts
from mrss.edge.rejection_reports import RejectionReporter
from mrss.edge.rejections import process_counts
from mrss.errors import ConfigError, SupervisionError
from mrss.runtime.component import Component, ComponentContext
from mrss.supervision import control
from mrss.supervision.reason import EXIT_CONFIG, Cause
from mrss.supervision.threads import tune_interpreter

EXIT_FAILED = 1
EXIT_INJECTED = 70
BUS_LOG_FLUSH = 0.5  # seconds an ending incarnation gives its last log records to go out
REPORT_TICK = 0.5  # seconds between two looks at the refusal counters


def load_class(target: str, project_dir: str | None = None) -> type[Component]:
    """Import `module.path:Class` (the project folder first on sys.path)."""
    module_name, sep, class_name = target.partition(":")
    if not sep or not module_name or not class_name:
        raise SupervisionError(f"component target {target!r} is not 'module.path:Class'")
    if project_dir and project_dir not in sys.path:
        sys.path.insert(0, project_dir)
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise SupervisionError(f"cannot import {module_name!r} for {target!r}: {exc}") from exc
    cls = getattr(module, class_name, None)
    if not isinstance(cls, type) or not issubclass(cls, Component):
        raise SupervisionError(f"{target!r} is not a subclass of mrss Component")
    return cls


class _Runtime:
    """One incarnation's lifecycle around a Component instance."""

    def __init__(self, ctx: ComponentContext, channel: socket.socket | None) -> None:
        self.ctx = ctx
        self.channel = channel
        self.log = ctx.log

    def _send(self, kind: str, text: str = "") -> None:
        if self.channel is not None:
            control.send(self.channel, kind, text)

    def _on_signal(self, signum: int, frame: FrameType | None) -> None:
        self.ctx._stop.set()

    def _reader(self) -> None:
        assert self.channel is not None
        while True:
            try:
                packet = self.channel.recv(control.MAX_PACKET)
            except OSError:
                packet = b""
            if not packet:  # the supervisor is gone: do not outlive it
                self.log.warning("control channel closed; stopping")
                self.ctx._stop.set()
                return
            kind, text = control.decode(packet)
            if kind == control.PING:
                self._send(control.PONG, text)
            elif kind == control.CRASH:
                self._send(control.FAIL, "crashed: InjectedFault: injected crash")
                os._exit(EXIT_INJECTED)

    def _heartbeat(self, component: Component) -> None:
        interval = self.ctx.heartbeat_interval
        while not self.ctx._stop.wait(interval):
            try:
                ok = component.healthy()
            except Exception:
                self.log.exception("healthy() raised")
                ok = False
            if ok:
                self._send(control.HEARTBEAT)

    def _report_rejections(self) -> None:
        ctx = self.ctx
        reporter = RejectionReporter(ctx.name, lambda m: ctx.publisher.publish(m),
                                     counts=_refusals)
        while not ctx._stop.wait(REPORT_TICK):
            try:
                reporter.tick()
            except Exception as exc:  # the bus is gone: the next tick tries again
                self.log.debug("refusal counters not published: %r", exc)

    def run(self, cls: type[Component]) -> int:
        if threading.current_thread() is threading.main_thread():
            signal.signal(signal.SIGTERM, self._on_signal)
            signal.signal(signal.SIGINT, self._on_signal)
        if self.channel is not None:
            threading.Thread(target=self._reader, name="control", daemon=True).start()
        slow = float(self.ctx.faults.get("slow_start", 0) or 0)
        if slow > 0:
            self.ctx._stop.wait(slow)  # fault injection: a slow start
        try:
            component = cls()
            component.start(self.ctx)
        except Exception as exc:
            return self._failed("start", exc)
        self._send(control.READY)
        # What start() made (modules, the project, actors) lives as long as the process:
        # out of the collector's sight, a full collection walks only what came after
        # (the RCL's took ~35 ms, a stall of everything on the action path).
        gc.freeze()
        beat = threading.Thread(target=self._heartbeat, args=(component,), name="heartbeat",
                                daemon=True)
        beat.start()
        if self.ctx.bus:
            threading.Thread(target=self._report_rejections, name="rejections",
                             daemon=True).start()
        self.ctx._stop.wait()
        try:
            component.stop()
        except Exception as exc:
            return self._failed("stop", exc)
        if self.ctx._failure:
            self._send(control.FAIL, f"crashed: {self.ctx._failure[0]}")
            return EXIT_FAILED
        return 0

    def _failed(self, phase: str, exc: Exception) -> int:
        if isinstance(exc, ConfigError):  # bad configuration: its message says it all
            self.log.error("%s of %s failed: %s", phase, self.ctx.name, exc)
            if phase == "start":  # the supervisor does not restart it (docs/supervision.md)
                self._send(control.FAIL, f"{Cause.CONFIG_ERROR.value}: {exc}")
                return EXIT_CONFIG
        else:
            self.log.error("%s of %s failed:\n%s", phase, self.ctx.name,
                           "".join(traceback.format_exception(exc)).rstrip())
        self._send(control.FAIL, f"crashed: {type(exc).__name__} in {phase}: {exc}")
        return EXIT_FAILED


def _refusals() -> dict[str, int]:
    """What this process refused: at the edge, and at the bus's door (dead, unproven or
    replayed senders: mrss/bus/incarnations.py)."""
    return {**process_counts(), **refusal_counts()}


def run_component(
    target: str, name: str, incarnation: int, context_json: str, control_fd: int | None,
) -> int:
    """Run one component incarnation to its end; returns the process exit code."""
    tune_interpreter()
    channel = socket.socket(fileno=control_fd) if control_fd is not None else None
    try:
        ctx = ComponentContext.from_json(name, incarnation, context_json)
    except SupervisionError as exc:
        logging.getLogger(f"mrss.{name}").error("%s", exc)
        if channel is not None:
            control.send(channel, control.FAIL, f"crashed: {exc}")
        return EXIT_FAILED
    to_bus = install_logging(ctx, supervised=channel is not None)
    apply_scheduling(ctx.scheduling, ctx.log)  # before any thread of the component exists
    try:
        try:
            cls = load_class(target, str(ctx.project_dir))
        except SupervisionError as exc:
            ctx.log.error("%s", exc)
            if channel is not None:
                control.send(channel, control.FAIL, f"crashed: {exc}")
            return EXIT_FAILED
        return _Runtime(ctx, channel).run(cls)
    finally:
        if to_bus is not None:
            logs.remove_bus_handler(to_bus, timeout=BUS_LOG_FLUSH)


def apply_scheduling(scheduling: dict[str, Any], log: logging.Logger) -> None:
    """This process's nice value, real-time priority and CPUs from its `[components.<id>]`
    table (opt-in).

    A setting the OS refuses (a negative nice without CAP_SYS_NICE, CPUs this machine
    lacks) is logged and skipped: the component runs, only less favoured.
    """
    nice, cpus = scheduling.get("nice"), scheduling.get("cpus")
    # Linux keeps both per thread: set them on every thread there is; later ones inherit.
    threads = [int(t) for t in os.listdir("/proc/self/task")] if os.path.isdir(
        "/proc/self/task") else [0]
    if isinstance(nice, int):
        try:
            for tid in threads:
                os.setpriority(os.PRIO_PROCESS, tid, nice)
        except OSError as exc:
            log.warning("nice %d not applied: %s (a negative nice needs CAP_SYS_NICE, or "
                        "a RLIMIT_NICE that allows it)", nice, exc.strerror)
    realtime = scheduling.get("realtime")
    if isinstance(realtime, int):
        try:
            for tid in threads:
                os.sched_setscheduler(tid, os.SCHED_RR, os.sched_param(realtime))
        except OSError as exc:
            log.warning("realtime %d (SCHED_RR) not applied: %s (it needs CAP_SYS_NICE, or "
                        "a RLIMIT_RTPRIO that allows it)", realtime, exc.strerror)
    if isinstance(cpus, list) and cpus:
        try:
            for tid in threads:
                os.sched_setaffinity(tid, cpus)
        except OSError as exc:
            log.warning("cpus %s not applied: %s (this machine has CPUs %s)", cpus,
                        exc.strerror, sorted(os.sched_getaffinity(0)))


def install_logging(ctx: ComponentContext, *, supervised: bool) -> logs.BusLogHandler | None:
    """This process's log handlers: stderr, the run's log file (when supervised), the bus.

    Returns the bus handler (None without bus endpoints); records go on `log.<name>`
    through `ctx.publisher`, made on the handler's thread if the component has not yet.
    """
    logs.configure(ctx.name, file=logs.log_file(ctx.run_dir) if supervised else None)
    if not ctx.bus:
        return None
    return logs.install_bus_handler(
        logs.BusLogHandler(ctx.name, lambda msg: ctx.publisher.publish(msg)))


def _parse(argv: Sequence[str] | None) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="python -m mrss.runtime.main",
                                description="run one MRSS component")
    p.add_argument("target", help="module.path:Class of a Component subclass")
    p.add_argument("--name", required=True)
    p.add_argument("--inc", type=int, default=1)
    p.add_argument("--context", default="{}")
    p.add_argument("--control-fd", type=int, default=None)
    return p.parse_args(argv)


def main(argv: Sequence[str] | None = None) -> int:
    args = _parse(argv)
    logging.basicConfig(level=logging.INFO,
                        format=f"%(asctime)s {args.name}[{os.getpid()}] %(levelname)s %(message)s")
    context = args.context
    if context == "{}":
        context = json.dumps({"project_dir": os.getcwd(), "run_dir": os.getcwd()})
    started = time.monotonic()
    code = run_component(args.target, args.name, args.inc, context, args.control_fd)
    logging.getLogger(f"mrss.{args.name}").debug("ran %.3fs", time.monotonic() - started)
    return code


if __name__ == "__main__":
    sys.exit(main())
