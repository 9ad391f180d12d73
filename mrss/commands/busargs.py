"""Bus options shared by `mrss send`, `record` and `replay`: where the bus is, how long to wait.

A running system's bus is named by its run directory (`--run-dir`, the default ipc
sockets `bus-pub.sock` and `bus-sub.sock` there) or by the proxy's two endpoints
(`--endpoints FRONT,BACK`, e.g. for a `[bus] transport = "tcp"` project).
"""

from __future__ import annotations

import argparse
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import zmq

from mrss.bus import BusEndpoints, Publisher, sockets
from mrss.errors import BusError, ConfigError

DEFAULT_WAIT = 5.0


def add_bus_arguments(parser: argparse.ArgumentParser, *, again: bool = False) -> None:
    """--run-dir | --endpoints (exactly one must be given), and --timeout.

    `again`: a sub-parser repeating the options of its parent, so they may come before or
    after the sub-command; its defaults are suppressed and do not hide the parent's values.
    """
    unset: Any = argparse.SUPPRESS if again else None
    wait: Any = argparse.SUPPRESS if again else DEFAULT_WAIT
    parser.add_argument("--run-dir", type=Path, metavar="DIR", default=unset,
                        help="run directory of the running system (its ipc bus sockets)")
    parser.add_argument("--endpoints", metavar="FRONT,BACK", default=unset,
                        help="the bus proxy's frontend and backend endpoints, "
                             "e.g. tcp://127.0.0.1:5601,tcp://127.0.0.1:5602")
    parser.add_argument("--timeout", type=positive_float, metavar="S", default=wait,
                        help=f"how long to wait for the bus proxy (default {DEFAULT_WAIT:g} s)")


def endpoints_from_args(args: argparse.Namespace) -> BusEndpoints:
    """The endpoints `--run-dir` or `--endpoints` name; BusError says what is wrong."""
    run_dir, endpoints = getattr(args, "run_dir", None), getattr(args, "endpoints", None)
    if (run_dir is None) == (endpoints is None):
        raise BusError("give the bus as --run-dir DIR or as --endpoints FRONT,BACK (one of them)")
    if run_dir is not None:
        if not run_dir.is_dir():
            raise BusError(f"run directory {str(run_dir)!r} does not exist")
        try:
            return BusEndpoints.ipc(run_dir)
        except ConfigError as exc:
            raise BusError(str(exc)) from None
    parts = [p.strip() for p in str(endpoints).split(",")]
    if len(parts) != 2 or not all(parts):
        raise BusError(f"--endpoints needs FRONT,BACK (two endpoints), not {endpoints!r}")
    try:
        return BusEndpoints(parts[0], parts[1])
    except ConfigError as exc:
        raise BusError(f"--endpoints: {exc.reason}") from None


def no_bus_error(endpoint: str, timeout: float) -> BusError:
    """The error for a bus proxy that did not answer at `endpoint` within `timeout`."""
    missing = [p for p in BusEndpoints.paths_of([endpoint]) if not p.exists()]
    if missing:
        return BusError(f"no bus: {missing[0]} does not exist (waited {timeout:g} s; is the "
                        "system running, and is this its run directory?)")
    return BusError(f"no bus proxy answered at {endpoint} within {timeout:g} s "
                    "(is the system running?)")


@contextmanager
def connected_publisher(endpoints: BusEndpoints, src: str, timeout: float,
                        linger: float = 10.0) -> Iterator[Publisher]:
    """A publisher the proxy has joined, so what it sends now is forwarded (else BusError).

    It has a ZeroMQ context of its own, terminated on exit: that waits (up to `linger`
    seconds) until every message sent has gone to the proxy. A process that simply
    ended would drop what its I/O thread had not written yet.
    """
    context: sockets.Context = zmq.Context()
    publisher = Publisher(endpoints, src=src, linger=linger, batching=False, context=context)
    try:
        if not publisher.wait_connected(timeout):
            raise no_bus_error(endpoints.frontend, timeout)
        yield publisher
    finally:
        publisher.close()
        context.term()


MAX_SECONDS = 1e6  # about 11.6 days: longer waits overflow the OS's and ZeroMQ's timers


def positive_float(text: str) -> float:
    """An argparse type: a number of seconds greater than 0, at most MAX_SECONDS."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not 0 < value <= MAX_SECONDS:
        raise argparse.ArgumentTypeError(f"{text!r} must be a number of seconds greater "
                                         f"than 0 and at most {MAX_SECONDS:g}")
    return value


def number_in(low: float, high: float, what: str) -> Callable[[str], float]:
    """An argparse type: a number within [low, high]."""
    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(f"{text!r} is outside [{low:g}, {high:g}] "
                                             f"({what})")
        return value
    return parse

