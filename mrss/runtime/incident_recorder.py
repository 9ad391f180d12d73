"""The root's incident recorder: the mission's history, kept by the system in the run dir.

The root supervisor of `mrss supervise` owns the record: it outlives every component
it restarts, so nothing the components do is lost while one of them is down. It
subscribes to the mission's traffic on the bus (`mrss.incident.from_bus.TOPICS`;
robot telemetry is refused before it is decoded) and writes the supervisor's own
events (restarts, hangs, give-ups) as it emits them, so a restart of the bus proxy is
recorded too. A root started again on the same run dir appends to the same file.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Collection
from pathlib import Path

from mrss.bus import BusEndpoints, Subscriber
from mrss.incident.entries import Entry, IncidentKind
from mrss.incident.from_bus import TOPICS, Classifier
from mrss.incident.journal import IncidentJournal, incident_file
from mrss.messages import Command, Envelope, Message, Percept, SupEvent
from mrss.supervision.events import Publish

log = logging.getLogger("mrss.runtime.incident")
ROOT_SRC = "supervisor"  # the root's bus name: its events are written as emitted


def _telemetry(topic: bytes) -> bool:
    return topic.startswith(b"robot.") and topic.endswith(b".data")


class IncidentRecorder:
    """Writes the incident record of one run dir from the bus and the root's events."""

    def __init__(self, run_dir: Path, endpoints: BusEndpoints, *, project: str,
                 operator_topics: Collection[str] = (),
                 components: Collection[str] = (), project_dir: Path | None = None) -> None:
        self.project = project
        self.journal = IncidentJournal(incident_file(run_dir))
        self.classifier = Classifier(operator_topics=operator_topics, components=components,
                                     author=authors(project_dir))
        self._sub = Subscriber(endpoints, prefixes=list(TOPICS), name="incident-recorder",
                               skip=_telemetry)
        self.failures = 0

    def start(self) -> IncidentRecorder:
        self._write(Entry(time.time(), IncidentKind.RUN, f"{self.project} started",
                          subject=self.project, source=ROOT_SRC))
        self._sub.start(self.handle)
        return self

    def close(self) -> None:
        self._sub.close()
        self._write(Entry(time.time(), IncidentKind.RUN, f"{self.project} stopped",
                          subject=self.project, source=ROOT_SRC))
        self.journal.sync()
        self.journal.close()

    def handle(self, env: Envelope) -> None:
        if env.src == ROOT_SRC and isinstance(env.body, SupEvent):
            return  # written by `publishing` when emitted
        entry = self.classifier.entry(env)
        if entry is not None:
            self._write(entry)

    def publishing(self, publish: Publish) -> Publish:
        """`publish`, writing each of the root's supervision events first."""
        def record_and_publish(msg: Message) -> object:
            if isinstance(msg, SupEvent):
                entry = self.classifier.supervision(msg, time.time(), ROOT_SRC)
                if entry is not None:
                    self._write(entry)
            return publish(msg)
        return record_and_publish

    def _write(self, entry: Entry) -> None:
        try:
            self.journal.append(entry)
        except OSError as exc:  # a full disk must not take the root down
            self.failures += 1
            if self.failures == 1 or self.failures % 1000 == 0:
                log.error("incident record %s: %d rows not written: %s",
                          self.journal.path, self.failures, exc)





def authors(project_dir: Path | None) -> Callable[[Envelope], str]:
    """Who sent a bus command, for the record: "alice (operator)" when its session
    credential is good, "bob: refused (...)" when not, its sender when the project has
    no users or a supervised component sent it."""
    from mrss.auth.roles import BUS_COMMANDS, CommandKind, refusal
    from mrss.auth.sessions import claimed_user, verify
    from mrss.auth.store import AuthError, OperatorStore, configured, store_path
    from mrss.errors import ConfigError

    def author(env: Envelope) -> str:
        if env.inc > 0 or not configured(project_dir):
            return env.src
        assert project_dir is not None
        try:
            identity = verify(OperatorStore.load(store_path(project_dir)), env.op)
        except (AuthError, ConfigError, OSError) as exc:
            return f"{claimed_user(env.op) or env.src}: refused ({exc})"
        body = env.body
        kind = (CommandKind.PERCEPT if isinstance(body, Percept) else
                BUS_COMMANDS.get(body.command) if isinstance(body, Command) else None)
        why = refusal(identity.role, kind) if kind is not None else ""
        return f"{identity}: refused ({why})" if why else str(identity)
    return author
