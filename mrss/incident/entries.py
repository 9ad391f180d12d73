"""One row of the incident record: when, what kind, who, about what, in words and as data.

A row is a JSON object on one line of `incident.jsonl` (`mrss.incident.journal`):

```
{"seq": 12, "ts": 1765070000.5, "kind": "outcome", "level": "warning",
 "source": "rcl", "who": "", "subject": "survey(a1)", "text": "...", "detail": {...}}
```

`seq` counts the rows of one record from 1 (it goes on across restarts of the root),
`ts` is when it happened (the bus envelope's time), `who` the author of an operator
command (the dashboard's or `mrss send`'s bus name, or the MQTT topic of a command sent
over MQTT; a person's identity once operators log in).
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field
from enum import StrEnum
from typing import Any

from mrss.errors import MrssError


class IncidentKind(StrEnum):
    """What a row is about."""

    RUN = "run"                    # the root supervisor started or stopped the system
    GOAL = "goal"                  # the agent asked for an action towards a goal
    OUTCOME = "outcome"            # an action ended: succeeded, failed (why), cancelled
    OPERATOR = "operator"          # an operator command (dashboard, mrss send, MQTT)
    EVENT = "event"                # an outside event the events manager handled
    ROBOT = "robot"                # a robot lost or back (availability, link)
    SUPERVISION = "supervision"    # a component restarted, hung, quarantined, gave up
    GAVE_UP = "gave_up"            # the agent gave a goal up for good (agent.gave_up)
    REASSIGNED = "reassigned"      # a task moved to another robot (reassigned percept)
    ALLOCATION = "allocation"      # a task for a role was awarded or waits
    QUESTION = "question"          # the agent asked the operator; answered (by whom), timed out


class Level(StrEnum):
    """How much a row matters to the operator: an alert is what the dashboard raises."""

    INFO = "info"
    WARNING = "warning"
    ALERT = "alert"


FIELDS = ("seq", "ts", "kind", "level", "source", "who", "subject", "text", "detail")
_FIELD_SET = frozenset(FIELDS)
_KINDS = {k.value: k for k in IncidentKind}
_LEVELS = {v.value: v for v in Level}


class IncidentFileError(MrssError):
    """A line of an incident file that is not a row: where (line, byte offset) and why."""

    def __init__(self, file: str, line: int, offset: int, why: str) -> None:
        super().__init__(f"{file}:{line}: (byte {offset}) {why}")
        self.file = file
        self.line = line
        self.offset = offset
        self.why = why


@dataclass(frozen=True)
class Entry:
    """One row of the record."""

    ts: float
    kind: IncidentKind
    text: str
    subject: str = ""
    level: Level = Level.INFO
    source: str = ""
    who: str = ""
    detail: dict[str, Any] = field(default_factory=dict)
    seq: int = 0

    def to_json(self) -> str:
        row = asdict(self)
        row["kind"] = self.kind.value
        row["level"] = self.level.value
        return json.dumps({name: row[name] for name in FIELDS}, separators=(",", ":"),
                          default=str)

    @classmethod
    def from_row(cls, row: Any) -> Entry:
        """A row decoded from JSON; ValueError naming the field that is wrong."""
        if not isinstance(row, dict):
            raise ValueError(f"expected a JSON object, got {type(row).__name__}")
        unknown = [] if row.keys() <= _FIELD_SET else sorted(set(row) - _FIELD_SET)
        if unknown:
            raise ValueError(f"unknown field {unknown[0]!r} (fields: {', '.join(FIELDS)})")
        for name in ("seq", "ts", "kind", "text"):
            if name not in row:
                raise ValueError(f"missing field {name!r}")
        if not isinstance(row["seq"], int) or isinstance(row["seq"], bool):
            raise ValueError(f"field 'seq': expected an integer, got {row['seq']!r}")
        if not isinstance(row["ts"], (int, float)) or isinstance(row["ts"], bool):
            raise ValueError(f"field 'ts': expected a number, got {row['ts']!r}")
        kind = _KINDS.get(row["kind"]) if isinstance(row["kind"], str) else None
        if kind is None:
            raise ValueError(f"field 'kind': {row['kind']!r} is not one of "
                             f"{', '.join(IncidentKind)}")
        level = _LEVELS.get(row.get("level", "info"))
        if level is None:
            raise ValueError(f"field 'level': {row['level']!r} is not one of "
                             f"{', '.join(Level)}")
        for name in ("text", "subject", "source", "who"):
            if not isinstance(row.get(name, ""), str):
                raise ValueError(f"field {name!r}: expected a string, got {row[name]!r}")
        detail = row.get("detail", {})
        if not isinstance(detail, dict):
            raise ValueError(f"field 'detail': expected an object, got {detail!r}")
        return cls(ts=float(row["ts"]), kind=kind, text=row["text"],
                   subject=row.get("subject", ""), level=level, source=row.get("source", ""),
                   who=row.get("who", ""), detail=detail, seq=row["seq"])
