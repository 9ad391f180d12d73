"""What if: a recorded mission replayed through an edited agent, robots not involved.

The edited program runs on a scripted host (mrss.agentspeak.scripted) on virtual time:
the recording's inputs (whatif_timeline.py) are given in recorded order, the agent's
clock moved to each one's time first (its `.wait`s fire on the way). Each action the
edited agent asks for is paired with the earliest recorded request of the same text
(name and arguments) not yet paired, whenever either comes; a paired action ends as the
recorded one did, when it did (at once if that is already past). An action with no
recorded twin is a new decision: it stays open (no robot runs it). A query is answered
with the data layer's recorded answer to the same function and arguments (the latest
one by then), else the latest to that function; with none it fails.

The decisions are then compared in order: the first index where the two runs' actions
differ (or one run has no more) is the first difference.
"""

from __future__ import annotations

import json
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mrss.agentspeak.agent import Agent
from mrss.agentspeak.errors import AslSyntaxError
from mrss.agentspeak.scripted import QUERY, ScriptedHost
from mrss.agentspeak.terms import Struct, term_str
from mrss.recording.whatif_timeline import Decision, InputKind, Timeline, args_key


@dataclass
class WhatIf:
    """The two runs' decisions, in order, and the first index where they differ."""

    recorded: list[Decision]
    edited: list[Decision]
    refused: list[str] = field(default_factory=list)  # inputs the edited agent could not take
    open_at_end: int = 0

    @property
    def first_difference(self) -> int | None:
        for i, (a, b) in enumerate(zip(self.recorded, self.edited, strict=False)):
            if a.text != b.text:
                return i
        if len(self.recorded) != len(self.edited):
            return min(len(self.recorded), len(self.edited))
        return None


class _Run:
    """The edited agent on a scripted host, fed the timeline."""

    def __init__(self, program: Path, line: Timeline) -> None:
        self.line = line
        self.host = ScriptedHost(hold=True, virtual_time=True, on_action=self._on_action)
        self.edited: list[Decision] = []
        self.refused: list[str] = []
        self._handles: dict[int, str] = {}  # edited handle -> its text
        self._waiting_recorded: dict[str, deque[str]] = {}  # text -> unpaired uuids
        self._waiting_edited: dict[str, deque[int]] = {}  # text -> unpaired handles
        self._pair: dict[str, int] = {}  # recorded uuid -> edited handle
        self._outcomes: dict[str, tuple[bool, str]] = {}  # uuid -> ended as
        self._queries: list[int] = []
        self._due: list[tuple[int, bool, str]] = []  # completions to give after this step
        self.agent: Agent = self.host.load(program)

    def _on_action(self, handle: int, text: str) -> None:
        if text.startswith(f"{QUERY}("):
            self._queries.append(handle)
            return
        if text.split("(", 1)[0] in self.host.immediate:
            return
        name, args = _parts(text)
        self.edited.append(Decision(self.host.now, name, args, text))
        self._handles[handle] = text
        waiting = self._waiting_recorded.get(text)
        if waiting:
            self._paired(waiting.popleft(), handle)
        else:
            self._waiting_edited.setdefault(text, deque()).append(handle)

    def _paired(self, uuid: str, handle: int) -> None:
        self._pair[uuid] = handle
        outcome = self._outcomes.get(uuid)
        if outcome is not None:
            self._due.append((handle, *outcome))

    def _requested(self, uuid: str) -> None:
        text = self.line.decisions[uuid].text
        waiting = self._waiting_edited.get(text)
        if waiting:
            self._paired(uuid, waiting.popleft())
        else:
            self._waiting_recorded.setdefault(text, deque()).append(uuid)

    def _ended(self, uuid: str, ok: bool, cause: str) -> None:
        self._outcomes[uuid] = (ok, cause)
        handle = self._pair.get(uuid)
        if handle is not None:
            self._due.append((handle, ok, cause))

    def settle(self) -> None:
        """Reason until idle, giving the outcomes and answers that came due meanwhile."""
        self.agent.run_until_idle()
        while self._due or self._queries:
            due, self._due = self._due, []
            for handle, ok, cause in due:
                if handle in self.host.open:
                    self.host.complete(handle, ok, error=None if ok else cause)
            queries, self._queries = self._queries, []
            for handle in queries:
                self._answer(handle)
            self.agent.run_until_idle()

    def _answer(self, handle: int) -> None:
        query = self.host.queries.get(handle)
        if query is None:
            return
        function = str(_plain(query.args[0]))
        key = (function, args_key(_plain(query.args[1])))
        answers = self.line.answers.get(key) or max(
            (v for k, v in self.line.answers.items() if k[0] == function),
            key=lambda v: v[-1][0], default=None)
        now = self.host.now
        known = [a for a in answers or [] if a[0] <= now] or (answers or [])[:1]
        if not known or not known[-1][1]:
            self.host.complete(handle, False, reason=f"no recorded answer for {function}")
        else:
            self.host.answer(handle, known[-1][2])

    def advance(self, at: float) -> None:
        """Move the agent's clock to `at`, firing the `.wait`s due on the way."""
        self.settle()
        while True:
            due = self.agent.next_deadline()
            if due is None or due > at:
                break
            self.host.now = max(self.host.now, due)
            self.settle()
        self.host.now = max(self.host.now, at)

    def feed(self) -> None:
        for item in self.line.inputs:
            self.advance(item.at)
            if item.kind is InputKind.REQUESTED:
                self._requested(item.uuid)
            elif item.kind is InputKind.OUTCOME:
                self._ended(item.uuid, item.ok, item.cause)
            else:
                try:
                    if item.kind is InputKind.ADD:
                        self.agent.add_percept(item.literal)
                    else:
                        self.agent.remove_percept(item.literal)
                except AslSyntaxError:
                    self.refused.append(item.literal)
            self.settle()
        self.advance(self.line.span)


def what_if(program: Path, line: Timeline) -> WhatIf:
    """Run `program` through the timeline; its decisions beside the recorded ones.
    AslSyntaxError (with file:line:col) if the program does not parse."""
    run = _Run(program, line)
    run.feed()
    recorded = sorted(line.decisions.values(), key=lambda d: d.at)
    return WhatIf(recorded, run.edited, run.refused, len(run.host.open))


def _plain(term: Any) -> Any:
    """A query argument as data, as the reasoner's host sends it: atoms as strings,
    lists as lists, anything else as its text."""
    if isinstance(term, (bool, int, float, str)):
        return term
    if isinstance(term, (tuple, list)):
        return [_plain(x) for x in term]
    if isinstance(term, Struct) and not term.args and not term.annots and not term.neg:
        return term.functor
    return term_str(term)


def _parts(text: str) -> tuple[str, tuple[Any, ...]]:
    """name and arguments of an action's text (`cover(uav1,a1)`)."""
    name, _, rest = text.partition("(")
    if not rest:
        return name, ()
    depth, current, args = 0, "", []
    for ch in rest[:-1]:
        if ch == "," and depth == 0:
            args.append(current)
            current = ""
            continue
        depth += ch in "([{"
        depth -= ch in ")]}"
        current += ch
    args.append(current)
    return name, tuple(_value(a.strip()) for a in args)


def _value(text: str) -> Any:
    """An argument's text as the reasoner's host sends it: a number, else text."""
    try:
        return int(text)
    except ValueError:
        pass
    try:
        return float(text)
    except ValueError:
        return text.strip('"')


def report(result: WhatIf) -> str:
    """Where the decisions first differ, then both runs' actions side by side."""
    lines = []
    first = result.first_difference
    if first is None:
        lines.append(f"no difference: the edited agent took the same {len(result.recorded)} "
                     "decisions, in the same order")
    else:
        def say(run: list[Decision]) -> str:
            if first >= len(run):
                return "(nothing more)"
            d = run[first]
            return f"{d.name} on {d.robot or '-'}, arguments {json.dumps(list(d.args[1:]))}" \
                   f" at +{d.at:.1f} s"
        lines.append(f"first difference: decision {first + 1}")
        lines.append(f"  recorded: {say(result.recorded)}")
        lines.append(f"  edited:   {say(result.edited)}")
    rows: list[tuple[int, str, str, str]] = []
    for i in range(max(len(result.recorded), len(result.edited))):
        cells = [f"+{run[i].at:7.1f} s {run[i].text}" if i < len(run) else "-"
                 for run in (result.recorded, result.edited)]
        same = i < min(len(result.recorded), len(result.edited)) and \
            result.recorded[i].text == result.edited[i].text
        rows.append((i + 1, " " if same else "*", cells[0], cells[1]))
    width = max([len("recorded"), *(len(row[2]) for row in rows)])
    lines += ["", f"{'#':>4}  {'recorded':<{width}}  edited"]
    lines += [f"{n:>4}{mark} {was:<{width}}  {now}" for n, mark, was, now in rows]
    if result.refused:
        lines.append(f"percepts the edited agent could not read: {len(result.refused)}")
    return "\n".join(lines)
