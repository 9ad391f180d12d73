"""The line protocol of `mrss agent FILE --stdin`: percepts and action outcomes, scripted.

One command per line (blank lines and `# comments` are skipped); after each line the
agent reasons until idle. What the agent does is printed as it happens:
`action N: LIT` (N numbers the action), `cancel N: LIT`, `.print` lines, answers to `?`.

    +LIT          perceive LIT                    -LIT         stop perceiving LIT
    !GOAL         post the achievement goal +!GOAL
    ok N [TERM]   action N succeeded; for `query(F, Args, R)`, TERM is bound to R
    fail N [CAUSE]  action N failed, the plan sees -!g[error(CAUSE)] (default action_failed)
    wait S        reason for S seconds (timers of `.wait` fire)
    ? LIT         print `yes` or `no`: whether the agent believes LIT

A line that does not parse, or names an action that is not open, is reported on stderr
as `stdin:LINE: problem (expected ...)` and skipped; the agent goes on.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from mrss.agentspeak.agent import Agent
from mrss.agentspeak.errors import AslSyntaxError
from mrss.agentspeak.host import run_until_idle_by
from mrss.agentspeak.parser import parse_literal, parse_term
from mrss.agentspeak.scripted import ScriptedHost
from mrss.agentspeak.terms import Struct, term_str

USAGE = "+LIT, -LIT, !GOAL, ok N [TERM], fail N [CAUSE], wait S or ? LIT"


class ScriptLineError(ValueError):
    """A line of the script that cannot be applied (the message says what was expected)."""


class StillBusy(Exception):
    """The agent was still reasoning when the script's time limit for a line ran out."""


@dataclass
class AgentScript:
    """Applies script lines to an agent on a ScriptedHost."""

    agent: Agent
    host: ScriptedHost
    out: Callable[[str], None]
    max_time: float | None = None  # seconds of reasoning a line may take (StillBusy after)
    _deadline: float | None = field(default=None, init=False)

    def apply(self, line: str) -> None:
        """Apply one line (ScriptLineError if it is malformed), then reason until idle
        (StillBusy if that takes more than `max_time`)."""
        self._deadline = None if self.max_time is None else time.monotonic() + self.max_time
        text = line.strip()
        if not text or text.startswith("#"):
            self.reason()
            return
        word, _, rest = text.partition(" ")
        rest = rest.strip()
        try:
            if text[0] in "+-!":
                literal = text[1:].strip()
                parse_literal(literal)  # a clear error before it reaches the agent
                {"+": self.agent.add_percept, "-": self.agent.remove_percept,
                 "!": self.agent.add_goal}[text[0]](literal)
            elif word == "?":
                self.reason()
                self.out("yes" if self.agent.believes(rest) else "no")
                return
            elif word in ("ok", "fail"):
                self._outcome(word == "ok", rest)
            elif word == "wait":
                self._wait(_number(rest, "wait S (seconds)"))
            else:
                raise ScriptLineError(f"unknown command {word!r} (expected {USAGE})")
        except AslSyntaxError as exc:
            raise ScriptLineError(f"{exc.args[0] if exc.args else exc} (expected {USAGE})"
                                  ) from None
        self.reason()

    def reason(self) -> None:
        """Reason until idle, within this line's time limit (StillBusy past it)."""
        if not run_until_idle_by(self.agent, self._deadline):
            raise StillBusy

    def _outcome(self, ok: bool, rest: str) -> None:
        handle_text, _, extra = rest.partition(" ")
        if not handle_text.isdigit():
            form = "ok N [TERM]" if ok else "fail N [CAUSE]"
            raise ScriptLineError(f"{form.split()[0]} needs an action number, not "
                                  f"{handle_text!r} (expected {form})")
        handle = int(handle_text)
        if handle not in self.host.open:
            open_ = ", ".join(f"{h}: {t}" for h, t in self.host.open.items()) or "none"
            raise ScriptLineError(f"no open action {handle} (open: {open_})")
        extra = extra.strip()
        if ok and handle in self.host.queries:
            if not extra:
                raise ScriptLineError(f"action {handle} is a query: ok {handle} TERM")
            self.host.answer_term(handle, parse_value(extra))
        elif ok:
            self.host.complete(handle, True)
        else:
            self.host.complete(handle, False, error=extra or None)

    def _wait(self, seconds: float) -> None:
        end = time.monotonic() + seconds
        if self._deadline is not None:  # `wait` lasts at most the line's time limit
            end = self._deadline = min(end, self._deadline)
        self.reason()
        while (left := end - time.monotonic()) > 0:
            self.agent.wait_for_work(min(left, 1.0))
            self.reason()


def parse_value(text: str) -> str:
    """Any one term (number, atom, string, list, structure) as canonical AgentSpeak text."""
    wrapped = parse_term(f"answer({text})")
    if not isinstance(wrapped, Struct) or len(wrapped.args) != 1:
        raise ScriptLineError(f"{text!r} is not one term (expected e.g. 42, a1, [1,2], \"s\")")
    return term_str(wrapped.args[0])


def _number(text: str, expected: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise ScriptLineError(f"{text!r} is not a number (expected {expected})") from None
    if not math.isfinite(value):
        raise ScriptLineError(f"{text!r} is not a finite number (expected {expected})")
    if value < 0:
        raise ScriptLineError(f"{text!r} is negative (expected {expected})")
    return value
