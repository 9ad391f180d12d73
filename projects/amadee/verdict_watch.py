"""Verdicts back to the operator: each request's legality verdict, pushed over MQTT.

The data layer stores the verdict on a request with goal G as the world model object
`verdict_G` when the reasoner asks for it. The events adapter `expect`s every goal it
turns into a percept; this watcher looks for the verdict in the world model (every
`interval` s, for at most `patience` s) and publishes it once on the verdict topic:

    {"goal": "g3", "legal": false, "rule": "no_go_path",
     "detail": "the path ... crosses no_go zone 'salt_marsh'",
     "action": "drive(rover1,g3,39.7725,44.801)"}

A goal id names one request: a verdict already stored under it when the request
arrives is the old one, and is skipped until it changes.
"""

from __future__ import annotations

import json
import logging
import threading
import time
from collections.abc import Callable
from typing import Any

from mrss.api import WorldModelRejected, WorldModelUnavailable

Lookup = Callable[[str], "dict[str, Any] | None"]
Publish = Callable[[str], object]


class VerdictWatch:
    """Waits for the verdicts of expected goals and publishes each one once."""

    def __init__(self, lookup: Lookup, publish: Publish, *, interval: float = 0.2,
                 patience: float = 60.0, log: logging.Logger | None = None) -> None:
        self.lookup, self.publish = lookup, publish
        self.log = log or logging.getLogger("amadee.verdicts")
        self.interval, self.patience = interval, patience
        self._pending: dict[str, tuple[float, str]] = {}   # goal -> (deadline, old action)
        self.failing = False                                # the last lookup failed
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="verdicts", daemon=True)

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=2.0)

    def expect(self, goal: str) -> None:
        """Publish the verdict on `goal` once the reasoner has asked for it."""
        old = self._attributes(goal)
        with self._lock:
            self._pending[goal] = (time.monotonic() + self.patience,
                                   json.dumps(old, sort_keys=True) if old else "")

    def _attributes(self, goal: str) -> dict[str, Any] | None:
        try:
            found = self.lookup(f"verdict_{goal}")
        except (WorldModelUnavailable, WorldModelRejected) as exc:
            if not self.failing:     # once per outage, not once per poll
                self.log.warning("verdict on %s: %s (trying again every %g s)", goal, exc,
                                 self.interval)
            self.failing = True
            return None
        if self.failing:
            self.failing = False
            self.log.warning("verdicts readable again")
        return None if found is None else dict(found.get("attributes") or {})

    def _run(self) -> None:
        while not self._stop.wait(self.interval):
            with self._lock:
                pending = dict(self._pending)
            for goal, (deadline, old) in pending.items():
                attrs = self._attributes(goal)
                if attrs and json.dumps(attrs, sort_keys=True) != old:
                    self.publish(json.dumps({"goal": goal, "legal": attrs.get("legal"),
                                             "rule": attrs.get("rule", ""),
                                             "detail": attrs.get("detail", ""),
                                             "action": attrs.get("action", "")}))
                elif time.monotonic() < deadline:
                    continue
                with self._lock:
                    self._pending.pop(goal, None)
