"""Environment actions: how an agent's actions leave for its host and come back.

The rules: an environment action of a plan body goes to the host's `execute`, with the
id of its intention, and the intention waits (`WAIT_ACTION`, off the run queue) on the
handle the host returned. With no host, or if `execute` raises, the action fails at
once (`action_failed`). The host reports the outcome later, from any thread, through
`Agent.complete_action`; the agent applies it in its own cycle (`process_completion`):
success resumes the intention, but a result term must unify with the action literal
or the action fails; a failure fails the goal with `action_failed` or the error the
host named. A completion for an intention dropped meanwhile, or an unknown handle, is
ignored. Dropping an intention cancels its action at the host (`cancel`); a host that
cannot cancel is a warning. With goal-state meta-events on, the wait and the resumption
are reported as goal states.
"""

from __future__ import annotations

from collections.abc import Hashable
from typing import TYPE_CHECKING, Protocol

from mrss.agentspeak import goals, goalstates
from mrss.agentspeak.errors import AslRuntimeError
from mrss.agentspeak.intentions import RUNNABLE, WAIT_ACTION, Intention
from mrss.agentspeak.terms import Struct, Term, term_str
from mrss.agentspeak.unify import unify

if TYPE_CHECKING:
    from mrss.agentspeak.runtime import Runtime


class Host(Protocol):
    """Where environment actions go. `execute` returns a handle; the host later calls
    `agent.complete_action(handle, success)` (from any thread). `cancel` is called
    when the intention waiting on the action is dropped.

    A host may declare `open_actions`, a set of action functors whose arguments may
    hold free variables (e.g. MRSS's `query(Function, Args, Result)`): their
    completion may carry a result term, unified with the action literal."""

    def execute(self, action: Struct, intention_id: int) -> Hashable: ...

    def cancel(self, handle: Hashable) -> None: ...


def start_action(rt: Runtime, it: Intention, lit: Struct, line: int) -> None:
    if rt.host is None:
        raise AslRuntimeError(f"no host to execute action {term_str(lit)}",
                              error="action_failed")
    try:
        handle = rt.host.execute(lit, it.id)
    except Exception as exc:  # the host's failure is the action's failure
        raise AslRuntimeError(f"action {term_str(lit)} failed at the host: {exc}",
                              error="action_failed") from exc
    it.state = WAIT_ACTION
    it.action = handle
    it.action_lit = lit
    it.line = line
    rt.pending_actions[handle] = it
    if rt.plans.meta:
        goalstates.emit_top(rt, it, goalstates.GoalState.WAITING,
                            Struct("action", (lit,)))


def process_completion(rt: Runtime, handle: Hashable, ok: bool, reason: str | None,
                       result: Term | None = None, error: str | None = None) -> None:
    it = rt.pending_actions.pop(handle, None)
    if it is None or it.dropped:
        return  # dropped or unknown: late feedback is ignored
    it.action = None
    lit, it.action_lit = it.action_lit, None
    if ok and result is not None and lit is not None and not unify(lit, None, result, []):
        ok, reason = False, f"result {term_str(result)} does not match {term_str(lit)}"
    if ok:
        if rt.plans.meta and not it.suspended:  # else `.resume` resumes it
            goalstates.emit_top(rt, it, goalstates.GoalState.RESUMED)
        rt.make_runnable(it)
        rt.pop_finished(it)
    else:
        im = it.stack[-1]
        it.state = RUNNABLE
        goals.fail(rt, it, error or "action_failed",
                   f"action failed: {reason or 'failure'}", im.plan.file, it.line)


def cancel_action(rt: Runtime, it: Intention) -> None:
    handle = it.action
    if handle is None:
        return
    it.action = None
    rt.pending_actions.pop(handle, None)
    if rt.host is not None:
        try:
            rt.host.cancel(handle)
        except Exception as exc:
            rt.warn(f"host could not cancel action {handle!r}: {exc}")
