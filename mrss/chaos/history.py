"""The history of a chaos campaign: what happened, as records, and its JSON-lines file.

One record per line, `{"type": ..., "t": ..., ...}`. `t` is seconds since the campaign
started (the recorder's monotonic clock for what it saw itself; wall-clock sources, the
RCL journal and the run's log file, are moved onto the same time line with the campaign's
start wall time). Record types:

    campaign   first line: project, seed, options, the planned faults, start wall time,
               the robots' capabilities (`robots`) and the award bound derived from the
               project (`award_bound`, mrss.chaos.task_bound)
    bus        a bus message as received: topic, src, inc, kind, body (its fields)
    fault      a fault injected: kind, target, pid, duration (s, 0 for instant), ok, error;
               a robot_loss also `holding`, the tasks addressed to a role its robot ran
    heal       a timed fault ended (SIGCONT sent, file size limit restored)
    operator   an operator step published over MQTT: intent, goal, robot, on, ..., ok
    reply      an MQTT message the system sent the operator (on the project's reply topics)
    probe      a look at the system after the faults: mind snapshot, open journal actions,
               the supervision tree (any may be null when it did not answer)
    journal    the RCL journal at the end: actions, transitions, robots' teleop flags, and
               what its compaction dropped: `compacted` actions, every terminal action
               last updated before `compacted_before` (campaign time)
    logline    a line of the run's log file (`<run_dir>/mrss.log`), with its creation time
    log        the run's log file was read: how many lines were kept, or why it could not be
    end        last line: when the faults ended, the system's exit code

`load` reads a file back into a `History`, checking each record, so the checker runs
offline on a file (`mrss chaos --check FILE`) exactly as at the end of a campaign.
"""

from __future__ import annotations

import json
import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

from mrss.errors import MrssError

FILE_NAME = "chaos-history.jsonl"


class HistoryError(MrssError):
    """A history file that cannot be read: names the file, the line and what is wrong."""


@dataclass(frozen=True)
class BusEvent:
    t: float
    topic: str
    src: str
    inc: int
    kind: str
    body: dict[str, Any]


@dataclass(frozen=True)
class FaultEvent:
    t: float
    kind: str
    target: str
    pid: int
    duration: float
    ok: bool
    error: str = ""
    holding: tuple[str, ...] = ()  # robot_loss: the tasks its robot ran when it was lost


@dataclass(frozen=True)
class HealEvent:
    t: float
    kind: str
    target: str
    pid: int


@dataclass(frozen=True)
class OperatorEvent:
    """One operator step: `intent` is goal | cancel | priority | mode."""

    t: float
    intent: str
    topic: str
    payload: dict[str, Any]
    ok: bool
    goal: str = ""
    robot: str = ""
    mode: str = ""
    on: bool = False
    error: str = ""
    attempts: int = 1  # sent again while the system did not answer


@dataclass(frozen=True)
class Reply:
    t: float
    topic: str
    payload: str


@dataclass(frozen=True)
class OpenAction:
    """A non-terminal action of the journal, as a probe saw it."""

    uuid: str
    state: str
    robot: str
    goal: str
    requester: str
    requester_inc: int


@dataclass(frozen=True)
class Probe:
    t: float
    mind: dict[str, Any] | None
    open_actions: list[OpenAction] | None
    tree: dict[str, Any] | None
    system_running: bool = True


@dataclass(frozen=True)
class JournalAction:
    uuid: str
    name: str
    robot: str
    goal: str
    state: str
    reason: str
    requester: str
    requester_inc: int
    created: float


@dataclass(frozen=True)
class JournalTransition:
    seq: int
    uuid: str
    state: str
    reason: str
    t: float


@dataclass(frozen=True)
class Journal:
    t: float
    actions: list[JournalAction] = field(default_factory=list)
    transitions: list[JournalTransition] = field(default_factory=list)
    teleop: dict[str, bool] = field(default_factory=dict)
    error: str = ""
    compacted: int = 0  # actions the journal's compaction dropped (their rows are gone)
    compacted_before: float | None = None  # ... every terminal one updated before this


@dataclass(frozen=True)
class LogLine:
    t: float
    component: str
    pid: int
    level: str
    message: str


@dataclass(frozen=True)
class LogRead:
    """The run's log file read at the end: lines kept, or the error that stopped it."""

    t: float
    file: str
    lines: int
    error: str = ""


@dataclass
class History:
    """A whole campaign, records grouped by type, each list in time order."""

    campaign: dict[str, Any] = field(default_factory=dict)
    bus: list[BusEvent] = field(default_factory=list)
    faults: list[FaultEvent] = field(default_factory=list)
    heals: list[HealEvent] = field(default_factory=list)
    operator: list[OperatorEvent] = field(default_factory=list)
    replies: list[Reply] = field(default_factory=list)
    probes: list[Probe] = field(default_factory=list)
    journal: Journal | None = None
    loglines: list[LogLine] = field(default_factory=list)
    log: LogRead | None = None
    end: dict[str, Any] = field(default_factory=dict)

    @property
    def faults_ended_at(self) -> float:
        """When the last fault was over (its heal, or its injection for instant ones)."""
        ends = [f.t for f in self.faults if f.ok] + [h.t for h in self.heals]
        return float(self.end.get("faults_ended", max(ends, default=0.0)))

    def of_kind(self, kind: str) -> list[BusEvent]:
        return [e for e in self.bus if e.kind == kind]


# -- writing ------------------------------------------------------------------------------
class HistoryWriter:
    """Appends records to the history file as they happen; thread-safe, flushed per line."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self._lock = threading.Lock()
        self._file: IO[str] | None = path.open("w", encoding="utf-8")
        self.count = 0

    def write(self, record_type: str, **fields: Any) -> None:
        line = json.dumps({"type": record_type, **fields}, default=_plain,
                          separators=(",", ":"))
        with self._lock:
            if self._file is None:
                return
            self._file.write(line + "\n")
            self._file.flush()
            self.count += 1

    def close(self) -> None:
        with self._lock:
            if self._file is not None:
                self._file.close()
                self._file = None


def _plain(value: Any) -> Any:
    if isinstance(value, (bytes, bytearray)):
        return value.hex()
    if isinstance(value, (set, frozenset, tuple)):
        return list(value)
    return str(value)


# -- reading ------------------------------------------------------------------------------
def load(path: Path) -> History:
    """Read a history file; HistoryError names the line and the problem."""
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except OSError as exc:
        raise HistoryError(f"{path}: cannot read: {exc.strerror}") from exc
    history = History()
    for number, line in enumerate(lines, 1):
        if not line.strip():
            continue
        try:
            record = json.loads(line)
            if not isinstance(record, dict):
                raise ValueError("a record must be a JSON object")
            _add(history, record)
        except (ValueError, KeyError, TypeError) as exc:
            raise HistoryError(f"{path}:{number}: bad record: {exc}") from None
    if not history.campaign:
        raise HistoryError(f"{path}: no campaign record; not a chaos history")
    return history


def parse(records: list[dict[str, Any]]) -> History:
    """A History from records as dicts (what the file holds, one per line)."""
    history = History()
    for record in records:
        _add(history, record)
    return history


def _add(h: History, r: dict[str, Any]) -> None:
    kind = r["type"]
    if kind == "campaign":
        h.campaign = dict(r)
    elif kind == "bus":
        h.bus.append(BusEvent(float(r["t"]), str(r["topic"]), str(r["src"]), int(r["inc"]),
                              str(r["kind"]), dict(r["body"])))
    elif kind == "fault":
        h.faults.append(FaultEvent(float(r["t"]), str(r["kind"]), str(r["target"]),
                                   int(r.get("pid", 0)), float(r.get("duration", 0.0)),
                                   bool(r["ok"]), str(r.get("error", "")),
                                   tuple(str(u) for u in r.get("holding") or ())))
    elif kind == "heal":
        h.heals.append(HealEvent(float(r["t"]), str(r["kind"]), str(r["target"]),
                                 int(r.get("pid", 0))))
    elif kind == "operator":
        h.operator.append(OperatorEvent(
            float(r["t"]), str(r["intent"]), str(r["topic"]), dict(r["payload"]),
            bool(r["ok"]), str(r.get("goal", "")), str(r.get("robot", "")),
            str(r.get("mode", "")), bool(r.get("on", False)), str(r.get("error", "")),
            int(r.get("attempts", 1))))
    elif kind == "reply":
        h.replies.append(Reply(float(r["t"]), str(r["topic"]), str(r["payload"])))
    elif kind == "probe":
        opens = r.get("open_actions")
        h.probes.append(Probe(
            float(r["t"]), r.get("mind"),
            None if opens is None else [_open_action(o) for o in opens], r.get("tree"),
            bool(r.get("system_running", True))))
    elif kind == "journal":
        h.journal = Journal(
            float(r["t"]), [_journal_action(a) for a in r.get("actions", [])],
            [JournalTransition(int(x["seq"]), str(x["uuid"]), str(x["state"]),
                               str(x["reason"]), float(x["t"]))
             for x in r.get("transitions", [])],
            {str(k): bool(v) for k, v in dict(r.get("teleop", {})).items()},
            str(r.get("error", "")), int(r.get("compacted", 0)),
            None if r.get("compacted_before") is None else float(r["compacted_before"]))
    elif kind == "logline":
        h.loglines.append(LogLine(float(r["t"]), str(r["component"]), int(r["pid"]),
                                  str(r["level"]), str(r["message"])))
    elif kind == "log":
        h.log = LogRead(float(r["t"]), str(r.get("file", "")), int(r.get("lines", 0)),
                        str(r.get("error", "")))
    elif kind == "end":
        h.end = dict(r)
    else:
        raise ValueError(f"unknown record type {kind!r}")


def _open_action(o: dict[str, Any]) -> OpenAction:
    return OpenAction(str(o["uuid"]), str(o["state"]), str(o["robot"]), str(o["goal"]),
                      str(o["requester"]), int(o["requester_inc"]))


def _journal_action(a: dict[str, Any]) -> JournalAction:
    return JournalAction(str(a["uuid"]), str(a["name"]), str(a["robot"]), str(a["goal"]),
                         str(a["state"]), str(a["reason"]), str(a["requester"]),
                         int(a["requester_inc"]), float(a["created"]))
