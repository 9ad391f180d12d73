"""Where a supervised child is in its life: one transition table, with causes, for both
supervisors (the root's component processes and the actor supervisors inside them).

A child's state changes only by `move(state, cause)`, which looks the pair up in
`TRANSITIONS` and raises for a pair the table does not have:

| cause \\ from | starting | running | stopping | waiting | quarantined | stopped |
|---|---|---|---|---|---|---|
| started | | | | starting | starting | starting |
| ready | running | | | | | |
| stop_asked | stopping | stopping | stopping | stopped | stopped | stopped |
| stopped | | | stopped | | | |
| stopped_to_restart | | | waiting | | | |
| stopped_to_quarantine | | | quarantined | | | |
| exited | stopped | stopped | | | | |
| restart_due | | | | waiting | waiting | waiting |
| given_up | | | | quarantined | quarantined | quarantined |
| probation_over | | | | | waiting | |
| abandoned | stopped | stopped | stopped | stopped | stopped | stopped |

* started: a new incarnation is launched (a process spawned, an actor's start hook
  called); the actor supervisor starts a released child straight from quarantine;
* ready: it reported ready (the process's ready message, the start hook returned);
* stop_asked: its supervisor stops it (a strategy, a give-up, shutdown); a child that
  is down stays down;
* stopped / stopped_to_restart / stopped_to_quarantine: it ended after being asked,
  for good, to be started again, or to sit out its group's probation;
* exited: it ended unasked (a crash, an exit, a hang, a start timeout, a launch that
  failed): the restart policy decides what follows;
* restart_due: the policy restarts it (after its backoff);
* given_up: over its restart budget: out until its probation is over;
* probation_over: the root's quarantined child waits for its start again;
* abandoned: its supervisor is gone or gave up as a whole: it is stopped, whatever it was.

Pure: no I/O; `tests/supervision/test_child_states.py` checks this table against the code.
"""

from __future__ import annotations

from collections.abc import Mapping
from enum import StrEnum

from mrss.errors import SupervisionError
from mrss.supervision.status import ChildState


class ChildCause(StrEnum):
    """Why a child's state changes (see the module's table)."""

    STARTED = "started"
    READY = "ready"
    STOP_ASKED = "stop_asked"
    STOPPED = "stopped"
    STOPPED_TO_RESTART = "stopped_to_restart"
    STOPPED_TO_QUARANTINE = "stopped_to_quarantine"
    EXITED = "exited"
    RESTART_DUE = "restart_due"
    GIVEN_UP = "given_up"
    PROBATION_OVER = "probation_over"
    ABANDONED = "abandoned"


_S = ChildState
_C = ChildCause
_DOWN = (_S.WAITING, _S.QUARANTINED, _S.STOPPED)
_UP = (_S.STARTING, _S.RUNNING)

TRANSITIONS: Mapping[tuple[ChildState, ChildCause], ChildState] = {
    **{(s, _C.STARTED): _S.STARTING for s in _DOWN},
    (_S.STARTING, _C.READY): _S.RUNNING,
    **{(s, _C.STOP_ASKED): _S.STOPPING for s in (*_UP, _S.STOPPING)},
    **{(s, _C.STOP_ASKED): _S.STOPPED for s in _DOWN},
    (_S.STOPPING, _C.STOPPED): _S.STOPPED,
    (_S.STOPPING, _C.STOPPED_TO_RESTART): _S.WAITING,
    (_S.STOPPING, _C.STOPPED_TO_QUARANTINE): _S.QUARANTINED,
    **{(s, _C.EXITED): _S.STOPPED for s in _UP},
    **{(s, _C.RESTART_DUE): _S.WAITING for s in _DOWN},
    **{(s, _C.GIVEN_UP): _S.QUARANTINED for s in _DOWN},
    (_S.QUARANTINED, _C.PROBATION_OVER): _S.WAITING,
    **{(s, _C.ABANDONED): _S.STOPPED for s in ChildState},
}


def move(state: ChildState, cause: ChildCause, child: str = "") -> ChildState:
    """The state `cause` moves a child in `state` to; SupervisionError if it cannot."""
    try:
        return TRANSITIONS[state, cause]
    except KeyError:
        raise SupervisionError(f"child {child or '?'}: {cause.value} while {state.value} "
                               "is no transition of mrss/supervision/child_states.py") from None


def table_rows() -> list[str]:
    """The module docstring's table, from `TRANSITIONS` (a test keeps the two equal)."""
    states = [_S.STARTING, _S.RUNNING, _S.STOPPING, _S.WAITING, _S.QUARANTINED, _S.STOPPED]
    rows = ["| cause \\ from | " + " | ".join(s.value for s in states) + " |",
            "|---|" + "---|" * len(states)]
    for cause in ChildCause:
        cells = [TRANSITIONS[s, cause].value if (s, cause) in TRANSITIONS else ""
                 for s in states]
        rows.append(f"| {cause.value} | " + " | ".join(cells) + " |")
    return rows
