"""The bus side of `mrss bench restart`: a component that answers pings, and its harness.

`BusEcho` is the bench project's component: it answers `Command(command="ping",
target=<its name>)` on `ctl.ping` with a `LogRecord` on `log.<name>.pong` whose message
is JSON: the ping's `seq`, the process id, and when (CLOCK_MONOTONIC, ns) it entered
`start`, its publisher was joined by the proxy, its subscriber was greeted by the proxy,
and it heard its first ping. The envelope's `inc` tells the incarnation.

`BusRestarts` runs a generated project (the bus proxy, then `BusEcho`) under a real
`mrss supervise` process, as a user runs it; the bench process is a bus client like
the TUI. It SIGKILLs the echo process and pings it every `PING_EVERY` seconds until
the new incarnation answers.
"""

from __future__ import annotations

import json
import os
import signal
import threading
import time
from dataclasses import dataclass
from typing import Any

from mrss.bench.harness import SupervisedProject
from mrss.bus import BusEndpoints, Publisher, Subscriber
from mrss.errors import BusError
from mrss.messages import Command, Envelope, LogRecord, SupEvent
from mrss.runtime.component import Component, ComponentContext

PROJECT = "benchbus"
ECHO = "echo"
PING_EVERY = 0.001
# Where the time of one restart goes, in order (the names of the `marks` in a pong).
PHASES = (("start", "kill -> start() called"),
          ("pub", "-> publisher joined by the proxy"),
          ("sub", "-> subscription at the proxy"),
          ("ping", "-> first ping heard"),
          ("pong", "-> pong at the bench"))


def project_toml(launcher: str, nice: int | None = None, realtime: int | None = None) -> str:
    """The bench project: the proxy first, then the echo; restarts without backoff."""
    favoured = ("" if nice is None else f"nice = {nice}\n") + \
        ("" if realtime is None else f"realtime = {realtime}\n")
    return f"""\
[project]
name = "{PROJECT}"

[supervisor]
strategy = "one_for_one"
intensity = 1000000
period = 1.0
healthy_after = 0.0
heartbeat_interval = 0.5
launcher = "{launcher}"

[components.bus]
kind = "bus"
{favoured}
[components.{ECHO}]
module = "mrss.bench.restart_peers:BusEcho"
shutdown = 2.0
{favoured}"""


class BusEcho(Component):
    """Answers pings addressed to it on the bus; ready once the proxy knows both ways."""

    def __init__(self) -> None:
        self.ctx: ComponentContext | None = None
        self._sub: Subscriber | None = None
        self._pub: Publisher | None = None
        self._marks: dict[str, int] = {}
        self._lock = threading.Lock()

    def start(self, ctx: ComponentContext) -> None:
        self._marks["start"] = time.monotonic_ns()
        self.ctx = ctx
        self._pub = ctx.publisher  # made on first use; waits until the proxy subscribed
        self._marks["pub"] = time.monotonic_ns()
        sub = Subscriber(BusEndpoints.from_dict(ctx.bus), prefixes=["ctl.ping"],
                         name=f"{ctx.name}-ping")
        self._sub = sub
        sub.start(self._on)
        if not sub.wait_connected(timeout=5.0):
            raise BusError(f"{ctx.name}: the bus proxy did not greet the ping subscriber")
        with self._lock:  # a ping may have been answered first: then that was the time
            self._marks.setdefault("sub", time.monotonic_ns())

    def _on(self, env: Envelope) -> None:
        body, ctx = env.body, self.ctx
        if ctx is None or not isinstance(body, Command) or body.command != "ping" \
                or body.target != ctx.name:
            return
        with self._lock:
            now = time.monotonic_ns()
            self._marks.setdefault("sub", now)
            self._marks.setdefault("ping", now)
            marks = dict(self._marks)
        reply = {"seq": body.args.get("seq"), "pid": os.getpid(), "marks": marks}
        assert self._pub is not None
        self._pub.publish(LogRecord(component=ctx.name, level="INFO",
                                    message=json.dumps(reply)), topic=f"log.{ctx.name}.pong")

    def stop(self) -> None:
        if self._sub is not None:
            self._sub.close()


@dataclass(frozen=True)
class Answer:
    """The first pong of one incarnation, as the bench received it."""

    inc: int
    pid: int
    marks: dict[str, int]  # CLOCK_MONOTONIC ns, see PHASES; "pong" = received here
    seq: int  # of the first ping it heard

    @property
    def transit_ms(self) -> float:
        """How long that ping took from the bench's publish to the echo's handler."""
        return (self.marks["ping"] - self.marks["sent"]) / 1e6


def _running_pids(tree: object) -> list[int]:
    """The pids of the echo's running incarnation in a `sup.tree` event's tree."""
    children = tree.get("children") if isinstance(tree, dict) else None
    return [child["pid"] for child in children or []
            if isinstance(child, dict) and child.get("id") == ECHO
            and child.get("state") == "running" and isinstance(child.get("pid"), int)]


class BusRestarts:
    """`mrss supervise` of the bench project, with the bench's own bus client."""

    def __init__(self, launcher: str, nice: int | None = None,
                 realtime: int | None = None) -> None:
        self._cond = threading.Condition()
        self._answers: dict[int, Answer] = {}
        self._running: set[int] = set()
        self._seq = 0
        self._sent: dict[int, int] = {}  # ping seq -> published, ns (current wait only)
        self.system = SupervisedProject(
            PROJECT, {"project.toml": project_toml(launcher, nice, realtime)},
            prefixes=[f"log.{ECHO}.pong", "sup.start", "sup.tree"], on_message=self._on,
            tmp_prefix="mrss-bench-restart-", nice=nice, realtime=realtime)
        self.tmp, self.proc = self.system.tmp, self.system.proc
        self.sub, self.pub = self.system.sub, self.system.pub

    def _on(self, env: Envelope) -> None:
        now = time.monotonic_ns()
        body = env.body
        with self._cond:
            if isinstance(body, LogRecord) and env.src == ECHO:
                if env.inc in self._answers:
                    return
                try:
                    reply: dict[str, Any] = json.loads(body.message)
                    seq = int(reply["seq"])
                    marks = {**reply["marks"], "pong": now, "sent": self._sent[seq]}
                    answer = Answer(env.inc, int(reply["pid"]), marks, seq)
                except (ValueError, KeyError, TypeError):
                    return  # not a pong of ours
                self._answers[env.inc] = answer
            elif isinstance(body, SupEvent) and body.event == "start" and body.child == ECHO:
                self._running.add(body.pid)
            elif isinstance(body, SupEvent) and body.event == "tree":
                self._running.update(_running_pids(body.detail.get("tree")))
            else:
                return
            self._cond.notify_all()

    def ping_until(self, inc: int, timeout: float = 30.0) -> Answer:
        """Ping every PING_EVERY s until incarnation `inc` (or a later one) answers."""
        deadline = time.monotonic() + timeout
        while True:
            self._seq += 1
            with self._cond:
                self._sent[self._seq] = time.monotonic_ns()
            self.pub.publish(Command(command="ping", target=ECHO, args={"seq": self._seq}))
            with self._cond:
                if self._cond.wait_for(lambda: any(i >= inc for i in self._answers),
                                       timeout=PING_EVERY):
                    self._sent.clear()
                    return self._answers[min(i for i in self._answers if i >= inc)]
            if time.monotonic() > deadline or self.proc.poll() is not None:
                raise TimeoutError(f"incarnation {inc} of {ECHO} did not answer on the bus; "
                                   f"log in {self.tmp / 'supervise.log'}")

    def wait_running(self, pid: int, timeout: float = 10.0) -> None:
        """Until the root lists `pid` as running (its `sup.start`, else a `ctl.tree` query)."""
        deadline = time.monotonic() + timeout
        while True:
            with self._cond:
                if self._cond.wait_for(lambda: pid in self._running, timeout=0.05):
                    return
            if time.monotonic() > deadline:
                raise TimeoutError(f"the root did not report {ECHO} pid {pid} running")
            self.pub.publish(Command(command="tree"))

    def restarts(self, kills: int) -> list[tuple[int, Answer]]:
        """Kill the echo `kills` times; each result is (kill time ns, first answer)."""
        if not self.sub.wait_connected(timeout=30):
            raise TimeoutError("the bench's subscriber was not greeted by the bus proxy")
        answer = self.ping_until(1, timeout=60)
        results: list[tuple[int, Answer]] = []
        for _ in range(kills):
            self.wait_running(answer.pid)
            killed = time.monotonic_ns()
            os.kill(answer.pid, signal.SIGKILL)
            answer = self.ping_until(answer.inc + 1)
            results.append((killed, answer))
        return results

    def close(self) -> None:
        self.system.close()


def bus_restarts(kills: int, launcher: str, nice: int | None = None,
                 realtime: int | None = None) -> list[tuple[int, Answer]]:
    """(kill time, first answer of the replacement) for `kills` kills, the first dropped."""
    harness = BusRestarts(launcher, nice, realtime)
    try:
        results = harness.restarts(kills + 1)  # the first one warms caches and is dropped
    finally:
        harness.close()
    return results[1:]
