"""`mrss recording report`: a recording's mission figures (mission_figures.py), read from
the file, as Markdown tables or JSON."""

from __future__ import annotations

import tomllib
from collections.abc import Iterator
from typing import IO, Any

from mrss.config.operator import OperatorCommand, read_operator
from mrss.errors import ConfigError, DecodeError
from mrss.messages import Envelope, decode
from mrss.recording.format import RecordingError
from mrss.recording.mcap_reader import McapRecording
from mrss.recording.mission_figures import FigureCounter, Figures, GoalOutcome


def operator_topics(project_toml: str) -> tuple[set[str], str]:
    """The topics of a project's operator interventions (its `[operator]` topics but the
    area's, and its own commands'); a warning when the file does not say."""
    try:
        operator = read_operator(tomllib.loads(project_toml).get("operator"),
                                 file="project.toml (kept in the recording)")
    except (tomllib.TOMLDecodeError, ConfigError) as exc:
        return set(), f"its project.toml is not valid ({exc}): MQTT operator events not counted"
    topics = {topic for command, topic in operator.topics.items()
              if command is not OperatorCommand.AREA}
    topics.update(spec.topic for spec in operator.commands.values())
    return topics, ""


class MissionReport:
    """Reads a recording once; `figures`, `warnings`, and `damage` (the RecordingError
    where a cut or damaged file stops: the figures are of what comes before it)."""

    def __init__(self, source: IO[bytes]) -> None:
        self._recording = McapRecording(source)  # RecordingError at once: not MRSS MCAP
        self.warnings: list[str] = []
        self.damage: RecordingError | None = None
        self.project = ""
        counter = FigureCounter()
        try:
            for env, at in self._envelopes(counter):
                counter.take(env, at)
        except RecordingError as exc:
            self.damage = exc
        self.figures = counter.figures()

    def _envelopes(self, counter: FigureCounter) -> Iterator[tuple[Envelope, float]]:
        configured = False
        for message in self._recording.recorded():
            if not configured:  # the project's metadata comes before the first message
                configured = True
                self._configure(counter)
            if message.malformed:
                continue
            try:
                yield decode(*message.frames), message.t
            except DecodeError:
                continue  # recorded as valid by a writer that did not check: not counted
        if not configured:
            self._configure(counter)

    def _configure(self, counter: FigureCounter) -> None:
        project = self._recording.metadata.get("project")
        if project is None:
            self.warnings.append("the recording has no project (mrss record --project "
                                 "NAME): MQTT operator events are not counted")
            return
        self.project = project.get("name", "")
        topics, warning = operator_topics(project.get("project.toml", ""))
        counter.operator_topics = frozenset(topics)
        if warning:
            self.warnings.append(warning)


def _s(value: float | None) -> str:
    return "-" if value is None else f"{value:.1f}"


def _since(figures: Figures, ts: float | None) -> float | None:
    return None if ts is None or figures.first is None else ts - figures.first


def as_dict(figures: Figures) -> dict[str, Any]:
    """The figures as JSON data (times in seconds from the recording's first message)."""
    goals = []
    for goal in figures.goals.values():
        goals.append({
            "goal": goal.name, "reported": _since(figures, goal.reported),
            "to_first_action": None if goal.reported is None or goal.first_action is None
            else goal.first_action - goal.reported,
            "to_done": None if goal.reported is None or goal.outcome is not GoalOutcome.DONE
            or goal.ended is None else goal.ended - goal.reported,
            "actions": len(goal.actions), "robots": sorted(goal.robots),
            "outcome": goal.outcome.value, "interventions": goal.interventions,
        })
    reported = figures.reported_goals
    done = [g for g in reported if g.outcome is GoalOutcome.DONE]
    return {
        "span_s": 0.0 if figures.first is None or figures.last is None
        else figures.last - figures.first,
        "goals": goals,
        "goals_reported": len(reported), "goals_done": len(done),
        "goals_done_without_operator": len(figures.without_operator),
        "share_done_without_operator": len(figures.without_operator) / len(reported)
        if reported else None,
        "actions": [{"robot": r, "state": s, "count": n}
                    for (r, s), n in sorted(figures.actions.items())],
        "failure_causes": [{"robot": r, "cause": c, "count": n}
                           for (r, c), n in sorted(figures.causes.items())],
        "restarts": dict(sorted(figures.restarts.items())),
        "faults": [{"event": e, "component": c, "count": n}
                   for (e, c), n in sorted(figures.faults.items())],
        "robot_losses": [{"at": _since(figures, ts), "robot": r, "why": why}
                         for ts, r, why in figures.losses],
        "reassignments": [{"at": _since(figures, ts), "what": what}
                          for ts, what in figures.reassignments],
        "interventions": [{"at": _since(figures, i.ts), "who": i.who, "what": i.what}
                          for i in figures.interventions],
        "interventions_per_hour": len(figures.interventions) / figures.hours
        if figures.hours > 0 else None,
    }


def _table(header: list[str], rows: list[list[str]]) -> list[str]:
    widths = [max(len(r[i]) for r in [header, *rows]) for i in range(len(header))]

    def line(cells: list[str]) -> str:
        return "| " + " | ".join(c.ljust(w) for c, w in zip(cells, widths, strict=True)) + " |"

    return [line(header), "|" + "|".join("-" * (w + 2) for w in widths) + "|",
            *map(line, rows)]


def to_text(figures: Figures, data: dict[str, Any]) -> str:
    """The report as Markdown: figures first, then the tables."""
    out = [f"span: {data['span_s']:.1f} s, from the first message to the last"]
    share = data["share_done_without_operator"]
    out.append(f"goals: {data['goals_reported']} reported, {data['goals_done']} done, "
               f"{data['goals_done_without_operator']} done without an operator"
               + (f" ({100 * share:.0f} % of the goals reported)" if share is not None
                  else ""))
    per_hour = data["interventions_per_hour"]
    out.append(f"operator interventions: {len(figures.interventions)}"
               + (f" ({per_hour:.1f} per hour)" if per_hour is not None else ""))
    out.append(f"restarts: {sum(figures.restarts.values())}, faults: "
               f"{sum(figures.faults.values())}, robot losses: {len(figures.losses)}, "
               f"reassignments: {len(figures.reassignments)}")
    rows = [[g["goal"], _s(g["reported"]), _s(g["to_first_action"]), _s(g["to_done"]),
             str(g["actions"]), ",".join(g["robots"]) or "-", g["outcome"],
             str(g["interventions"])] for g in data["goals"] if g["reported"] is not None]
    out += ["", "## Goals (times in s; reported: since the first message)", ""]
    out += _table(["goal", "reported", "to first action", "to done", "actions", "robots",
                   "outcome", "interventions"], rows) if rows else ["(none)"]
    service = [f"{g['goal']} ({g['actions']} actions, {g['outcome']})"
               for g in data["goals"] if g["reported"] is None]
    if service:
        out.append(f"\nnamed by actions, reported by no percept: {', '.join(service)}")
    robots = sorted({r for r, _ in figures.actions})
    states = ["succeeded", "failed", "cancelled"]
    rows = [[r, *(str(figures.actions.get((r, s), 0)) for s in states),
             ", ".join(f"{c} {n}" for (rr, c), n in sorted(figures.causes.items()) if rr == r)
             or "-"] for r in robots]
    out += ["", "## Actions per robot", ""]
    out += _table(["robot", *states, "failure causes"], rows) if rows else ["(none)"]
    children = sorted(set(figures.restarts) | {c for _, c in figures.faults})
    rows = [[c, str(figures.restarts.get(c, 0)),
             ", ".join(f"{e} {n}" for (e, cc), n in sorted(figures.faults.items()) if cc == c)
             or "-"] for c in children]
    out += ["", "## Restarts and faults", ""]
    out += _table(["component", "restarts", "faults"], rows) if rows else ["(none)"]
    for title, items in (("Robot losses", [f"+{x['at']:.1f} s {x['robot']}: {x['why']}"
                                           for x in data["robot_losses"]]),
                         ("Reassignments", [f"+{x['at']:.1f} s {x['what']}"
                                            for x in data["reassignments"]]),
                         ("Operator interventions", [f"+{x['at']:.1f} s {x['who']}: {x['what']}"
                                                     for x in data["interventions"]])):
        out += ["", f"## {title}", "", *(f"- {i}" for i in items or ["(none)"])]
    return "\n".join(out)

