"""Which failures of an edge event are worth retrying, and how long they are retried.

An external event becomes percepts in one attempt of its handler. The attempt ends one
of four ways (`Attempt`), decided here and nowhere else:

- ACCEPTED: the handler returned; its percepts go out.
- BAD_INPUT: the payload does not fit (`PayloadError`, `PredicateError`, `ValueError`,
  `KeyError`, `TypeError`): retrying cannot help, the sender is told at once.
- UNAVAILABLE: a dependency is down or slow (`DependencyUnavailable` and its kinds,
  such as `WorldModelUnavailable`; `TimeoutError`, `ConnectionError`): the event is
  tried again after a backoff, until the retry budget is spent.
- HANDLER_ERROR: anything else is a bug in the handler: not retried, reported.

`RetryPolicy` is the backoff: the first retry after `initial` seconds, each wait
`factor` times the previous up to `max_delay`, and no attempt starts after `budget`
seconds from the first one (`[events] retry_initial`, `retry_max_delay`,
`retry_budget`; defaults 0.2 s, 5 s, 30 s).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from enum import StrEnum
from typing import Any

from mrss.agentspeak.literals import PredicateError
from mrss.errors import ConfigError, DecodeError, TransientError


class DependencyUnavailable(TransientError):
    """Something an event handler needs (the world model, a service) is down or slow.

    Raise it from an adapter handler to have the event tried again later. It is a
    TransientError: raised in a skill or `refine_action`, the action fails `transient`.
    """


class Attempt(StrEnum):
    """How one attempt at turning an event into percepts ended."""

    ACCEPTED = "accepted"
    BAD_INPUT = "bad_input"
    UNAVAILABLE = "unavailable"
    HANDLER_ERROR = "handler_error"


# PayloadError is a DecodeError.
BAD_INPUT: tuple[type[BaseException], ...] = (DecodeError, PredicateError, ValueError,
                                              KeyError, TypeError)
TRANSIENT: tuple[type[BaseException], ...] = (DependencyUnavailable, TimeoutError,
                                              ConnectionError)


def classify(exc: BaseException) -> Attempt:
    """The outcome of an attempt that raised `exc` (transient kinds are checked first)."""
    if isinstance(exc, TRANSIENT):
        return Attempt.UNAVAILABLE
    if isinstance(exc, BAD_INPUT):
        return Attempt.BAD_INPUT
    return Attempt.HANDLER_ERROR


@dataclass(frozen=True)
class RetryPolicy:
    """Exponential backoff within a total budget (seconds)."""

    initial: float = 0.2
    factor: float = 2.0
    max_delay: float = 5.0
    budget: float = 30.0

    def delay(self, retry: int) -> float:
        """The wait before retry number `retry` (1 for the first retry)."""
        return float(min(self.max_delay, self.initial * self.factor ** max(0, retry - 1)))

    def next_wait(self, retry: int, elapsed: float) -> float | None:
        """The wait before retry `retry`, or None when it would start past the budget."""
        wait = self.delay(retry)
        return None if elapsed + wait > self.budget else wait

    @classmethod
    def from_config(cls, section: Mapping[str, Any]) -> RetryPolicy:
        """From `[events] retry_initial`, `retry_max_delay`, `retry_budget` (seconds)."""
        values: dict[str, float] = {}
        for key, attr in (("retry_initial", "initial"), ("retry_max_delay", "max_delay"),
                          ("retry_budget", "budget")):
            if key in section:
                value = section[key]
                if isinstance(value, bool) or not isinstance(value, (int, float)) \
                        or value < 0 or (attr != "budget" and value == 0):
                    raise ConfigError("must be a positive number of seconds",
                                      key=f"events.{key}")
                values[attr] = float(value)
        policy = cls(**values)
        if policy.max_delay < policy.initial:
            raise ConfigError("must be at least retry_initial", key="events.retry_max_delay")
        return policy
