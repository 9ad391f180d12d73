"""Helpers for tests and test procedures: condition waits, free ports, a private broker."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TypeVar

import psutil

from mrss.interpreter import python_module
from mrss.ports import free_port as free_port
from mrss.ports import free_udp_port as free_udp_port
from mrss.programs import find_mosquitto as find_mosquitto

T = TypeVar("T")


class WaitTimeout(AssertionError):
    """A condition did not hold within its timeout."""


MAX_STRETCH = 4.0  # a wait gets at most 4x its timeout on an overloaded machine


def stretch() -> float:
    """How much longer than its timeout a wait gets on this machine now: the run queue
    per CPU (the 1-minute load average) when above 1, at most MAX_STRETCH. A timeout in
    a test is a failure detector: on a host with 20 runnable processes for 2 CPUs
    everything takes several times as long, and a detector tuned for a quiet machine would
    call that a failure."""
    try:
        per_cpu = os.getloadavg()[0] / (os.cpu_count() or 1)
    except OSError:
        return 1.0
    return min(max(per_cpu, 1.0), MAX_STRETCH)


def expired(started: float, timeout: float) -> bool:
    """Whether a wait begun at `started` (time.monotonic()) with `timeout` is over, given
    the machine's load now (`stretch`)."""
    waited = time.monotonic() - started
    return waited >= timeout and waited >= timeout * stretch()


def wait_until(
    condition: Callable[[], T], timeout: float = 10.0, interval: float = 0.005,
    message: str = "condition",
) -> T:
    """Poll `condition` until it returns a truthy value; return it, or raise WaitTimeout.
    On a loaded machine the wait goes on past `timeout` in proportion (`stretch`)."""
    started = time.monotonic()
    while True:
        value = condition()
        if value:
            return value
        if time.monotonic() - started >= timeout and expired(started, timeout):
            raise WaitTimeout(f"{message} did not hold within {timeout:.1f}s"
                              f"{_stretched(started, timeout)}")
        time.sleep(interval)


def process_gone(pid: int) -> bool:
    """Whether process `pid` has ended: it is not there, or a zombie not reaped yet
    (one reaped between looking it up and reading its status is gone too)."""
    try:
        return bool(psutil.Process(pid).status() == psutil.STATUS_ZOMBIE)
    except psutil.NoSuchProcess:
        return True


def _stretched(started: float, timeout: float) -> str:
    waited = time.monotonic() - started
    return f" (waited {waited:.1f}s: the machine was loaded)" if waited > timeout * 1.05 else ""


@dataclass(frozen=True)
class BrokerInfo:
    """A running MQTT broker for a test: where it listens and what it is."""

    host: str
    port: int
    kind: str  # "mosquitto" | "amqtt"

    @property
    def url(self) -> str:
        return f"mqtt://{self.host}:{self.port}"


def _wait_port(host: str, port: int, timeout: float) -> None:
    def accepting() -> bool:
        try:
            with socket.create_connection((host, port), timeout=0.2):
                return True
        except OSError:
            return False

    wait_until(accepting, timeout=timeout, interval=0.02, message=f"broker on {host}:{port}")


@contextmanager
def mosquitto_broker(
    binary: str, host: str = "127.0.0.1", extra_config: str = "",
) -> Iterator[BrokerInfo]:
    """A private Mosquitto on a free loopback port, stopped on exit even after a failure.

    `extra_config` is appended to its configuration file. TCP_NODELAY is always on, so
    a test's round trip does not wait ~40 ms for Nagle's algorithm per hop.
    """
    port = free_port(host)
    with tempfile.TemporaryDirectory(prefix="mrss-mosq-") as tmp:
        conf = Path(tmp) / "mosquitto.conf"
        conf.write_text(
            f"listener {port} {host}\nallow_anonymous true\npersistence false\n"
            "set_tcp_nodelay true\n"
            "log_type error\nlog_type warning\n" + extra_config
        )
        with _broker_process([binary, "-c", str(conf)], host, port, 10.0):
            yield BrokerInfo(host, port, "mosquitto")


@contextmanager
def amqtt_broker(host: str = "127.0.0.1") -> Iterator[BrokerInfo]:
    """An embedded amqtt broker in a child process on a free loopback port."""
    port = free_port(host)
    argv = python_module("mrss.actors.broker.service", "--host", host, "--port", str(port))
    with _broker_process(argv, host, port, 20.0):
        yield BrokerInfo(host, port, "amqtt")


@contextmanager
def _broker_process(argv: list[str], host: str, port: int, timeout: float) -> Iterator[None]:
    """Run a broker until the block ends (even by an exception); wait for its port first."""
    proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        _wait_port(host, port, timeout=timeout)
        yield
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
        if proc.stderr:
            proc.stderr.close()


def stop_supervised(proc: subprocess.Popen[bytes] | subprocess.Popen[str],
                    timeout: float = 30.0) -> None:
    """Stop an `mrss supervise` process as an operator would (SIGTERM, an orderly stop),
    first waking any SIGSTOPped component of its tree so it can stop; kill the tree if
    it has not ended within `timeout` seconds."""
    if proc.poll() is not None:
        return
    tree = psutil.Process(proc.pid).children(recursive=True)
    for child in tree:
        try:
            child.send_signal(signal.SIGCONT)
        except psutil.NoSuchProcess:
            pass
    proc.send_signal(signal.SIGTERM)
    try:
        proc.wait(timeout=timeout)
    except subprocess.TimeoutExpired:
        for child in tree:
            try:
                child.kill()
            except psutil.NoSuchProcess:
                pass
        proc.kill()
        proc.wait(timeout=10)
