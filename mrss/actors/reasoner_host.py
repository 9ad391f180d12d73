"""The reasoner's host for its agent: environment actions become latched bus actions.

Every environment action the agent executes gets a uuid and goes to the RCL as an
`ActionRequest`; its intention stays blocked (the paper's latch) until a terminal
`ActionStatus` for that uuid comes back. Two actions are special:

- `rcl_goal_management(Command, Target)` sends an `ActionControl` and succeeds at once.
  Target is a goal id, `action(Uuid)` or `robot(R)`; `rcl_goal_management(C, Kind, T)`
  names the kind (`action`, `goal`, `robot`) explicitly.
- `query(Function, Args, Result)` asks the data layer and binds `Result` from its reply;
  an error reply or a timeout fails the action.

A blocked intention never waits forever: when the RCL has been silent for longer than
the lease, every latched action fails with the reason. Those actions are cancelled at
the RCL too (and again whenever a status shows one still open, e.g. after the RCL
comes back or restarts), so no robot keeps working for an intention that has failed.
"""

from __future__ import annotations

import logging
import threading
import time
import uuid as uuidlib
from collections import OrderedDict
from collections.abc import Callable, Hashable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any, Protocol

from mrss.agentspeak import Struct, term_str
from mrss.agentspeak.terms import PList
from mrss.edge.predicates import term as term_text
from mrss.errors import MrssError
from mrss.messages import (
    CONTROL_COMMANDS,
    CONTROL_TARGETS,
    ActionControl,
    ActionRequest,
    ActionState,
    ActionStatus,
)

log = logging.getLogger("mrss.reasoner")

GOAL_MANAGEMENT = "rcl_goal_management"
QUERY = "query"
ABANDONED_MEMORY = 4096  # uuids of lease-failed actions still to be seen ending at the RCL


class AgentPort(Protocol):
    """What the host needs of the agent: thread-safe completion of actions."""

    def complete_action(self, handle: Hashable, success: bool, reason: str | None = None,
                        result: str | Struct | None = None) -> None: ...


DataCall = Callable[[str, list[Any], float], Any]


@dataclass
class Latch:
    """An action the agent waits on."""

    uuid: str
    literal: str
    robot: str
    goal: str
    sent_at: float
    last_status: str = ActionState.PENDING.value
    status_at: float = 0.0
    progress: dict[str, Any] = field(default_factory=dict)


def plain_arg(t: Any) -> Any:
    """An action argument as a JSON-like value for the RCL (structures as their text)."""
    if isinstance(t, bool):
        return t
    if isinstance(t, (int, float, str)):
        return t
    if isinstance(t, tuple):
        return [plain_arg(x) for x in t]
    if isinstance(t, PList):
        return term_str(t)
    if isinstance(t, Struct) and not t.args and not t.annots and not t.neg:
        return t.functor
    return term_str(t)


def _annotation(action: Struct, name: str) -> Any:
    for a in action.annots:
        if isinstance(a, Struct) and a.functor == name and len(a.args) == 1:
            return a.args[0]
    return None


class ReasonerHost:
    """Turns the agent's environment actions into bus messages and latches."""

    open_actions = frozenset({QUERY})

    def __init__(self, send_request: Callable[[ActionRequest], object],
                 send_control: Callable[[ActionControl], object],
                 data_call: DataCall | None = None, *, lease: float = 10.0,
                 query_timeout: float = 5.0, clock: Callable[[], float] = time.monotonic
                 ) -> None:
        self.agent: AgentPort | None = None
        self._send_request = send_request
        self._send_control = send_control
        self._data_call = data_call
        self.lease = lease
        self.query_timeout = query_timeout
        self._clock = clock
        self._lock = threading.Lock()
        self._latches: dict[str, Latch] = {}
        self._abandoned: OrderedDict[str, None] = OrderedDict()
        self._queries: ThreadPoolExecutor | None = None
        self.rcl_heard_at = clock()
        self.rcl_incarnation = -1

    # ------------------------------------------------------------ the agent's side
    def execute(self, action: Struct, intention_id: int) -> Hashable:
        if action.functor == GOAL_MANAGEMENT:
            return self._goal_management(action)
        if action.functor == QUERY and len(action.args) == 3:
            return self._query(action)
        args = [plain_arg(a) for a in action.args]
        priority = _annotation(action, "priority")
        request = ActionRequest(
            uuid=uuidlib.uuid4().hex, name=action.functor, args=args,
            robot=str(args[0]) if args else "", goal=str(args[1]) if len(args) > 1 else "",
            priority=priority if isinstance(priority, int) else 0,
            literal=term_str(Struct(action.functor, action.args)),
        )
        now = self._clock()
        with self._lock:
            if not self._latches:
                self.rcl_heard_at = max(self.rcl_heard_at, now)  # the lease starts now
            self._latches[request.uuid] = Latch(request.uuid, request.literal, request.robot,
                                                request.goal, now, status_at=now)
        self._send_request(request)
        log.info("action %s %s sent", request.uuid, request.literal)
        return request.uuid

    def cancel(self, handle: Hashable) -> None:
        """The intention waiting on `handle` was dropped: the RCL cancels the action."""
        with self._lock:
            latch = self._latches.pop(str(handle), None)
        if latch is not None:
            self._send_control(ActionControl(command="cancel", target=latch.uuid,
                                             target_kind="action"))
            log.info("action %s %s cancelled (intention dropped)", latch.uuid, latch.literal)

    def _goal_management(self, action: Struct) -> Hashable:
        handle = f"gm-{uuidlib.uuid4().hex}"
        control = goal_management_control(action)
        self._send_control(control)
        self._complete(handle, True)
        return handle

    def _query(self, action: Struct) -> Hashable:
        handle = f"q-{uuidlib.uuid4().hex}"
        function = plain_arg(action.args[0])
        args = plain_arg(action.args[1])
        if self._data_call is None:
            raise MrssError("query/3: this reasoner has no data layer")
        if self._queries is None:
            self._queries = ThreadPoolExecutor(max_workers=4, thread_name_prefix="query")
        fn_args = args if isinstance(args, list) else [args]
        self._queries.submit(self._run_query, handle, action, str(function), fn_args)
        return handle

    def _run_query(self, handle: str, action: Struct, function: str, args: list[Any]) -> None:
        assert self._data_call is not None
        try:
            result = self._data_call(function, args, self.query_timeout)
            text = (f"{QUERY}({term_str(action.args[0])},{term_str(action.args[1])},"
                    f"{term_text(result)})")
        except Exception as exc:
            log.warning("query %s%s failed: %s", function, args, exc)
            self._complete(handle, False, f"query {function} failed: {exc}")
            return
        self._complete(handle, True, result=text)

    def _complete(self, handle: str, ok: bool, reason: str | None = None,
                  result: str | None = None) -> None:
        if self.agent is not None:
            self.agent.complete_action(handle, ok, reason, result=result)

    # ------------------------------------------------------------ the RCL's side
    def on_status(self, status: ActionStatus, src_inc: int) -> None:
        """A status from the RCL: a terminal one releases its latch."""
        terminal = ActionState(status.state).terminal
        abandoned = False
        with self._lock:
            if src_inc < self.rcl_incarnation:
                log.debug("dropped a status of dead RCL incarnation %d", src_inc)
                return
            self.rcl_incarnation = src_inc
            self.rcl_heard_at = self._clock()
            latch = self._latches.get(status.uuid)
            if latch is None:
                abandoned = status.uuid in self._abandoned
                if abandoned and terminal:
                    del self._abandoned[status.uuid]
            else:
                latch.last_status = status.state
                latch.status_at = self.rcl_heard_at
                latch.progress = dict(status.progress)
                if terminal:
                    del self._latches[status.uuid]
        if latch is None:
            if abandoned and not terminal:  # its intention failed on the lease: stop it
                self._cancel_abandoned(status.uuid)
            return
        if terminal:
            ok = status.state == ActionState.SUCCEEDED.value
            reason = None if ok else (status.reason or status.state)
            log.info("action %s %s %s%s", latch.uuid, latch.literal, status.state,
                     f": {status.reason}" if status.reason else "")
            self._complete(latch.uuid, ok, reason)

    def heard_from_rcl(self, src_inc: int) -> None:
        """Any message of the RCL (heartbeat, robot state) renews the lease."""
        with self._lock:
            if src_inc >= self.rcl_incarnation:
                self.rcl_incarnation = src_inc
                self.rcl_heard_at = self._clock()

    def check_lease(self) -> list[str]:
        """Fail every latched action if the RCL has been silent past the lease."""
        now = self._clock()
        with self._lock:
            if not self._latches or now - self.rcl_heard_at <= self.lease:
                return []
            expired = list(self._latches.values())
            self._latches.clear()
            for latch in expired:
                self._abandoned[latch.uuid] = None
            while len(self._abandoned) > ABANDONED_MEMORY:
                self._abandoned.popitem(last=False)
        silent = now - self.rcl_heard_at
        for latch in expired:
            self._complete(latch.uuid, False, f"RCL silent for {silent:.1f}s (lease "
                                              f"{self.lease:.1f}s)")
        log.warning("RCL silent for %.1fs: failed %d waiting action(s)", silent, len(expired))
        for latch in expired:  # queued for the RCL; repeated if it shows them open later
            self._cancel_abandoned(latch.uuid)
        return [latch.uuid for latch in expired]

    def _cancel_abandoned(self, uuid: str) -> None:
        self._send_control(ActionControl(command="cancel", target=uuid, target_kind="action"))
        log.info("action %s cancelled: its intention failed on the RCL lease", uuid)

    def latches(self) -> list[Latch]:
        with self._lock:
            return list(self._latches.values())

    def close(self) -> None:
        if self._queries is not None:
            self._queries.shutdown(wait=False, cancel_futures=True)


def goal_management_control(action: Struct) -> ActionControl:
    """The ActionControl of `rcl_goal_management(Command, Target)` (or `(C, Kind, T)`)."""
    args = action.args
    if len(args) not in (2, 3):
        raise MrssError(f"{GOAL_MANAGEMENT} takes (Command, Target) or (Command, Kind, "
                        f"Target), not {term_str(action)}")
    command = str(plain_arg(args[0]))
    if command not in CONTROL_COMMANDS:
        raise MrssError(f"{GOAL_MANAGEMENT}: unknown command {command!r}")
    if len(args) == 3:
        kind, target = str(plain_arg(args[1])), plain_arg(args[2])
    else:
        target_term = args[1]
        kind = "goal"
        if (isinstance(target_term, Struct) and len(target_term.args) == 1
                and target_term.functor in CONTROL_TARGETS):
            kind, target = target_term.functor, plain_arg(target_term.args[0])
        else:
            target = plain_arg(target_term)
    if kind not in CONTROL_TARGETS:
        raise MrssError(f"{GOAL_MANAGEMENT}: unknown target kind {kind!r}")
    return ActionControl(command=command, target=str(target), target_kind=kind)
