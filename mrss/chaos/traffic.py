"""Operator traffic for a campaign: what a project declares, and how it is sent.

A project declares its operator in `projects/<name>/chaos.py`, plain Python that needs
no MRSS import (see projects/wildfire/chaos.py and docs/chaos.md):

    REPLY_TOPICS = ["mrss/ui/reply/#"]      # MQTT topics where the system answers the operator
    PENDING_BELIEFS = ["queued", "task"]    # beliefs that show an operator goal is held
    MODE_BELIEFS = {"teleop": "paused({robot},teleop)"}   # a robot mode as a belief
    def operator_traffic(rng, every):       # an endless iterator of steps (dicts)
        yield {"after": 2.0, "intent": "goal", "goal": "a1", "topic": "mrss/ui/area",
               "payload": {...}}

A step's `intent` is one of `Intent`; `goal` names the goal of goal, cancel and priority
steps; mode steps name `robot`, `mode` and `on`. `after` is the pause (s) before the step.
A project without chaos.py gets no operator traffic. Steps are published as JSON with
QoS 1 on the broker named in the run folder (`broker.url`, read for every step, since a
restarted broker may move); a step is *accepted* when the broker acknowledges it, tried
again for up to `patience` seconds while the broker is down.
"""

from __future__ import annotations

import json
import os
import random
import time
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from enum import StrEnum
from pathlib import Path
from typing import Any

from mrss.errors import ConfigError
from mrss.links.mqtt_url import new_client, parse_broker_url
from mrss.runtime.loader import import_project_module

CHAOS_FILE = "chaos.py"


class Intent(StrEnum):
    GOAL = "goal"
    CANCEL = "cancel"
    PRIORITY = "priority"
    MODE = "mode"


@dataclass(frozen=True)
class OperatorStep:
    after: float
    intent: Intent
    topic: str
    payload: dict[str, Any]
    goal: str = ""
    robot: str = ""
    mode: str = ""
    on: bool = False


StepSource = Callable[[random.Random, float], Iterator[Mapping[str, Any]]]


@dataclass(frozen=True)
class Traffic:
    """A project's operator: its steps and how to read the system's answers."""

    file: str = ""
    source: StepSource | None = None
    reply_topics: tuple[str, ...] = ()
    pending_beliefs: tuple[str, ...] = ()
    mode_beliefs: dict[str, str] = field(default_factory=dict)

    def steps(self, seed: int, every: float) -> Iterator[OperatorStep]:
        """The operator's steps, checked one by one (ConfigError names the bad key)."""
        if self.source is None:
            return
        for number, raw in enumerate(self.source(random.Random(seed), every), 1):
            yield step_from(raw, f"{self.file}: operator_traffic step {number}")


def load_traffic(project_dir: Path) -> Traffic:
    """The operator traffic of a project (empty if it has no chaos.py)."""
    path = project_dir / CHAOS_FILE
    if not path.is_file():
        return Traffic()
    module = import_project_module(project_dir, CHAOS_FILE)
    source = getattr(module, "operator_traffic", None)
    if source is not None and not callable(source):
        raise ConfigError("must be a function (rng, every) -> iterator of steps",
                          file=str(path), key="operator_traffic")
    modes = getattr(module, "MODE_BELIEFS", {})
    if not isinstance(modes, dict) or not all(isinstance(k, str) and isinstance(v, str)
                                              for k, v in modes.items()):
        raise ConfigError("must map a mode name to a belief pattern with {robot}",
                          file=str(path), key="MODE_BELIEFS")
    return Traffic(str(path), source, _strings(module, "REPLY_TOPICS", path),
                   _strings(module, "PENDING_BELIEFS", path), dict(modes))


def _strings(module: Any, name: str, path: Path) -> tuple[str, ...]:
    value = getattr(module, name, ())
    if not isinstance(value, (list, tuple)) or not all(isinstance(v, str) for v in value):
        raise ConfigError("must be a list of strings", file=str(path), key=name)
    return tuple(value)


def step_from(raw: Mapping[str, Any], where: str) -> OperatorStep:
    """Check one declared step; ConfigError says which key is wrong and what is expected."""
    if not isinstance(raw, Mapping):
        raise ConfigError(f"{where}: a step must be a dict, not {type(raw).__name__}")

    def need(key: str, kind: type | tuple[type, ...], what: str, default: Any = None) -> Any:
        value = raw.get(key, default)
        if not isinstance(value, kind) or (isinstance(value, bool) and kind is not bool):
            raise ConfigError(f"{where}: expected {what}, got {value!r}", key=key)
        return value

    try:
        intent = Intent(str(raw.get("intent")))
    except ValueError:
        raise ConfigError(f"{where}: expected one of {', '.join(Intent)}",
                          key="intent") from None
    after = float(need("after", (int, float), "seconds", 0.0))
    if after < 0:
        raise ConfigError(f"{where}: expected seconds >= 0, got {after}", key="after")
    topic, payload = need("topic", str, "an MQTT topic"), need("payload", dict, "a dict")
    if intent is Intent.MODE:
        return OperatorStep(after, intent, topic, payload,
                            robot=need("robot", str, "a robot id"),
                            mode=need("mode", str, "a mode name"),
                            on=need("on", bool, "true or false"))
    return OperatorStep(after, intent, topic, payload, goal=need("goal", str, "a goal id"))


@dataclass(frozen=True)
class Sent:
    ok: bool
    error: str = ""


def publish(run_dir: Path, step: OperatorStep, patience: float = 10.0) -> Sent:
    """Publish one step (QoS 1); ok when the broker acknowledged it within `patience` s."""
    deadline = time.monotonic() + patience
    error = ""
    while True:
        try:
            _publish_once(run_dir, step.topic, json.dumps(step.payload))
            return Sent(True)
        except (OSError, ValueError, RuntimeError) as exc:
            error = f"{type(exc).__name__}: {exc}"
        if time.monotonic() >= deadline:
            return Sent(False, error)
        time.sleep(0.5)  # the broker is being restarted: an operator's UI tries again


def _publish_once(run_dir: Path, topic: str, payload: str) -> None:
    url = (run_dir / "broker.url").read_text(encoding="utf-8").strip()
    address = parse_broker_url(url)
    client = new_client(f"mrss-chaos-operator-{os.getpid()}", address)
    client.connect(address.host, address.port, keepalive=10)
    client.loop_start()
    try:
        info = client.publish(topic, payload, qos=1)
        info.wait_for_publish(timeout=3)
        if not info.is_published():
            raise RuntimeError(f"{topic}: not acknowledged by the broker within 3 s")
    finally:
        client.disconnect()
        client.loop_stop()
