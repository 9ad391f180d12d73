"""The reasoner's host for its agent: environment actions become latched bus actions.

Every environment action the agent executes gets a uuid and goes to the RCL as an
`ActionRequest`; its intention stays blocked (the paper's latch) until a terminal
`ActionStatus` for that uuid comes back. Three actions are special:

- `rcl_goal_management(Command, Target)` sends an `ActionControl` and succeeds at once.
  Target is a goal id, `action(Uuid)` or `robot(R)`; `rcl_goal_management(C, Kind, T)`
  names the kind (`action`, `goal`, `robot`) explicitly.
- `query(Function, Args, Result)` asks the data layer and binds `Result` from its reply;
  an error reply or a timeout fails the action.
- `give_up(Goal, Reason, Cause)` tells the operator the goal is given up for good
  (mrss.actors.reasoner.give_up) and succeeds at once.
- `ask_operator(...)`, from `.ask_operator`, waits for the operator's answer (questions.py).

A blocked intention never waits forever:
- reconciliation: every `reconcile` seconds while actions wait, the host asks the RCL for
  their statuses (`ActionQuery`); the RCL answers from its journal, so a terminal status
  lost on the bus (a proxy restart, an RCL restart) is heard within one period;
- lease: when the RCL has been silent for longer than the lease, or one action has had
  no status (nor reconciliation answer) for that long, the action fails with
  `error(transient)`. Such actions are cancelled at the RCL too (and again whenever a
  status shows one still open), so no robot keeps working for an intention that failed.

Adoption after a restart of the reasoner: a new incarnation first asks the RCL for the
inventory of what its predecessors left (`expect_inventory`); until it arrives (or
`adopt_wait` passes) new actions are held. An action whose literal matches one left
behind takes over that action's uuid: the RCL sees the same uuid from a newer
incarnation and lets this one wait for it, instead of cancelling and redoing it.

A failure reaches the agent with its cause (`-!g[error(Cause)]`): the RCL's
`FailureCause` (transient, link_down, cancelled, ...), or Jason's `action_failed`.
The translations themselves (a literal to a request or a control, a status to an
error) are mrss.actors.reasoner.messages.

One idea in one module: the latch between the agent's actions and whoever ends them
(the RCL, the data layer, the operator); what each special action does lives in its own
module (give_up.py, questions.py), only its routing here.
"""

from __future__ import annotations

import dataclasses
import logging
import threading
import time
import uuid as uuidlib
from collections import OrderedDict
from collections.abc import Callable, Hashable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any, Protocol

from mrss.actors.reasoner.adoption import adoptable
from mrss.actors.reasoner.give_up import GiveUps, is_give_up, of_action
from mrss.actors.reasoner.messages import (
    GOAL_MANAGEMENT,
    action_request,
    failure_error,
    goal_management_control,
    plain_arg,
)
from mrss.actors.reasoner.questions import OperatorQuestions, is_question
from mrss.agentspeak import Struct, term_str
from mrss.agentspeak.literals import term as term_text
from mrss.errors import MrssError
from mrss.messages import (
    ActionControl,
    ActionInventory,
    ActionQuery,
    ActionRequest,
    ActionState,
    ActionStatus,
    ControlCommand,
    ControlTarget,
    FailureCause,
)
from mrss.runtime.datalayer_client import DataLayerUnavailable

log = logging.getLogger("mrss.reasoner")

QUERY = "query"
ABANDONED_MEMORY = 4096  # uuids of lease-failed actions still to be seen ending at the RCL


class AgentPort(Protocol):
    """What the host needs of the agent: thread-safe completion of actions."""

    def complete_action(self, handle: Hashable, success: bool, reason: str | None = None,
                        result: str | Struct | None = None, error: str | None = None
                        ) -> None: ...


DataCall = Callable[[str, list[Any], float], Any]


@dataclass
class Latch:
    """An action the agent waits on."""

    uuid: str
    literal: str
    robot: str
    goal: str
    sent_at: float
    handle: str = ""  # what the agent waits on (the uuid, unless adopted another's)
    last_status: str = ActionState.PENDING.value
    status_at: float = 0.0
    progress: dict[str, Any] = field(default_factory=dict)


class ReasonerHost:
    """Turns the agent's environment actions into bus messages and latches."""

    open_actions = frozenset({QUERY})

    def __init__(self, send_request: Callable[[ActionRequest], object],
                 send_control: Callable[[ActionControl], object],
                 data_call: DataCall | None = None, *, lease: float = 10.0,
                 query_timeout: float = 5.0, clock: Callable[[], float] = time.monotonic,
                 send_query: Callable[[ActionQuery], object] | None = None,
                 reconcile: float = 1.0, adopt_wait: float = 3.0) -> None:
        self.agent: AgentPort | None = None
        self._send_request = send_request
        self._send_control = send_control
        self._send_query = send_query
        self._data_call = data_call
        self.lease = lease
        self.query_timeout = query_timeout
        self.reconcile_period = reconcile
        self.adopt_wait = adopt_wait
        self._clock = clock
        self._lock = threading.Lock()
        self._latches: dict[str, Latch] = {}  # by action uuid
        self._handles: dict[str, str] = {}  # agent handle -> action uuid
        self._abandoned: OrderedDict[str, None] = OrderedDict()
        self._queries: ThreadPoolExecutor | None = None
        self.rcl_heard_at = clock()
        self.rcl_incarnation = -1
        self._reconciled_at = clock()
        # adoption: None while no inventory is expected, else (requester, inc, deadline)
        self._awaiting: tuple[str, int, float] | None = None
        self._asked_at = -1.0
        self._held: list[ActionRequest] = []
        self._left: dict[str, list[str]] = {}  # literal -> uuids a predecessor left
        self.adopted = 0
        self.give_ups = GiveUps(None)  # the reasoner sets one that publishes
        self.questions: OperatorQuestions | None = None  # the reasoner sets them

    # ------------------------------------------------------------ the agent's side
    def execute(self, action: Struct, intention_id: int) -> Hashable:
        if action.functor == GOAL_MANAGEMENT:
            return self._goal_management(action)
        if action.functor == QUERY and len(action.args) == 3:
            return self._query(action)
        if is_give_up(action):
            return self.give_up(action, str(getattr(self.agent, "name", "")))
        if is_question(action):
            return self.ask(action, str(getattr(self.agent, "name", "")))
        request = action_request(action)
        now = self._clock()
        handle = request.uuid
        with self._lock:
            if not self._latches:
                self.rcl_heard_at = max(self.rcl_heard_at, now)  # the lease starts now
            self._latches[request.uuid] = Latch(request.uuid, request.literal, request.robot,
                                                request.goal, now, status_at=now,
                                                handle=request.uuid)
            self._handles[request.uuid] = request.uuid
            if self._awaiting is not None:  # adoption: wait for the inventory first
                self._held.append(request)
                log.info("action %s %s held until the RCL's inventory arrives",
                         request.uuid, request.literal)
                return request.uuid
            request = self._adopt(request)
        self._send_request(request)
        log.info("action %s %s sent", request.uuid, request.literal)
        return handle

    def action_uuid(self, handle: Hashable) -> Hashable:
        """The uuid the RCL knows for the action behind an intention's `handle`: after an
        adoption it is the predecessor's uuid, not the handle."""
        with self._lock:
            return self._handles.get(str(handle), handle)

    def _adopt(self, request: ActionRequest) -> ActionRequest:
        """Under the lock: take over a predecessor's action with the same literal."""
        left = self._left.get(request.literal)
        if not left:
            return request
        old = left.pop(0)
        latch = self._latches.pop(request.uuid)
        latch.uuid = old
        self._latches[old] = latch
        self._handles[latch.handle] = old
        self.adopted += 1
        log.info("action %s adopts %s, left by a previous incarnation", request.literal, old)
        return dataclasses.replace(request, uuid=old)

    def ask(self, action: Struct, agent: str) -> Hashable:
        """`ask_operator(...)` of the agent named `agent`: it waits for the answer."""
        if self.questions is None:
            raise MrssError("ask_operator: this reasoner has no question journal")
        return self.questions.ask(action, agent)

    def cancel(self, handle: Hashable) -> None:
        """The intention waiting on `handle` was dropped: the RCL cancels the action."""
        if self.questions is not None and self.questions.withdraw(handle):
            return
        with self._lock:
            uuid = self._handles.pop(str(handle), None)
            latch = self._latches.pop(uuid, None) if uuid is not None else None
            held = [r for r in self._held if r.uuid == uuid]
            self._held = [r for r in self._held if r.uuid != uuid]
        if latch is not None and not held:
            self._send_control(ActionControl(command=ControlCommand.CANCEL, target=latch.uuid,
                                             target_kind=ControlTarget.ACTION))
            log.info("action %s %s cancelled (intention dropped)", latch.uuid, latch.literal)

    def _goal_management(self, action: Struct) -> Hashable:
        handle = f"gm-{uuidlib.uuid4().hex}"
        control = goal_management_control(action)
        self._send_control(control)
        self.complete(handle, True)
        return handle

    def give_up(self, action: Struct, agent: str) -> Hashable:
        """`give_up(Goal, Reason, Cause)` of the agent named `agent`: the alert goes out,
        the action succeeds (fails with `error(rejected)` on a reason not of the set)."""
        handle = f"gu-{uuidlib.uuid4().hex}"
        try:
            alert = of_action(agent, action)
        except MrssError as exc:
            log.warning("%s: %s", agent, exc)
            self.complete(handle, False, str(exc), error=FailureCause.REJECTED.value)
            return handle
        self.give_ups.tell(alert)
        self.complete(handle, True)
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
            transient = isinstance(exc, DataLayerUnavailable)
            self.complete(handle, False, f"query {function} failed: {exc}",
                           error=FailureCause.TRANSIENT.value if transient else None)
            return
        self.complete(handle, True, result=text)

    def complete(self, handle: Hashable, ok: bool, reason: str | None = None,
                 result: str | Struct | None = None, error: str | None = None) -> None:
        """Release the intention waiting on `handle` (any thread)."""
        if self.agent is not None:
            self.agent.complete_action(handle, ok, reason, result=result, error=error)

    # ------------------------------------------------------------ adoption
    def expect_inventory(self, requester: str, inc: int) -> None:
        """This is incarnation `inc` of `requester`, restarted: hold new actions until the
        RCL says what the previous incarnations left (or `adopt_wait` passes)."""
        with self._lock:
            self._awaiting = (requester, inc, self._clock() + self.adopt_wait)
            self._asked_at = -1.0
        self.reconcile()

    def on_inventory(self, inventory: ActionInventory) -> None:
        """The RCL's inventory for this incarnation: adopt, then send what was held."""
        with self._lock:
            awaiting = self._awaiting
            if awaiting is None or (inventory.requester, inventory.inc) != awaiting[:2]:
                return
            self._left = adoptable(inventory.actions)
            log.info("inventory: %d action(s) left by earlier incarnations of %s",
                     len(inventory.actions), inventory.requester)
        self._release_held()

    def _release_held(self) -> None:
        with self._lock:
            self._awaiting = None
            held, self._held = self._held, []
            requests = [self._adopt(r) for r in held if r.uuid in self._latches]
        for request in requests:
            self._send_request(request)
            log.info("action %s %s sent", request.uuid, request.literal)

    # ------------------------------------------------------------ the RCL's side
    def on_status(self, status: ActionStatus, src_inc: int) -> None:
        """A status from the RCL: a terminal one releases its latch."""
        terminal = status.state.terminal
        abandoned = False
        with self._lock:  # a dead incarnation's statuses never get here (bus/incarnations.py)
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
                    self._handles.pop(latch.handle, None)
        if latch is None:
            if abandoned and not terminal:  # its intention failed on the lease: stop it
                self._cancel_abandoned(status.uuid)
            return
        if terminal:
            ok = status.state == ActionState.SUCCEEDED.value
            reason = None if ok else (status.reason or status.state)
            log.info("action %s %s %s%s", latch.uuid, latch.literal, status.state,
                     f": {status.reason}" if status.reason else "")
            self.complete(latch.handle, ok, reason,
                           error=None if ok else failure_error(status))

    def heard_from_rcl(self, src_inc: int) -> None:
        """Any message of the RCL (heartbeat, robot state) renews the lease."""
        with self._lock:
            self.rcl_incarnation = src_inc
            self.rcl_heard_at = self._clock()

    def reconcile(self) -> None:
        """Ask the RCL, when due, for the statuses of the waiting actions and, after a
        restart, for the inventory (called by the reasoner's loop)."""
        if self._send_query is None:
            return
        now = self._clock()
        inventory = release = False
        with self._lock:
            if self._awaiting is not None:
                if now >= self._awaiting[2]:
                    log.warning("no inventory from the RCL within %.1fs: nothing adopted",
                                self.adopt_wait)
                    release = True
                elif now - self._asked_at >= min(0.5, self.adopt_wait):
                    inventory, self._asked_at = True, now
            uuids = [u for u in self._latches if not any(r.uuid == u for r in self._held)]
            due = uuids and now - self._reconciled_at >= self.reconcile_period
            if due:
                self._reconciled_at = now
            awaiting = self._awaiting
        if release:
            self._release_held()
        if inventory and awaiting is not None:
            self._send_query(ActionQuery(requester=awaiting[0], inc=awaiting[1]))
        if due:
            self._send_query(ActionQuery(uuids=uuids))

    def check_lease(self) -> list[str]:
        """Fail the latched actions the RCL has not spoken of within the lease: all of
        them when the RCL is silent, one when only its status is missing."""
        now = self._clock()
        with self._lock:
            if not self._latches:
                return []
            silent = now - self.rcl_heard_at
            held = {r.uuid for r in self._held}
            if silent > self.lease:
                expired = [la for la in self._latches.values() if la.uuid not in held]
            elif self._send_query is not None:  # reconciliation refreshes each status
                expired = [la for la in self._latches.values()
                           if la.uuid not in held and now - la.status_at > self.lease]
            else:
                expired = []
            for latch in expired:
                del self._latches[latch.uuid]
                self._handles.pop(latch.handle, None)
                self._abandoned[latch.uuid] = None
            while len(self._abandoned) > ABANDONED_MEMORY:
                self._abandoned.popitem(last=False)
        if not expired:
            return []
        for latch in expired:
            quiet = min(silent, now - latch.status_at)
            self.complete(latch.handle, False, f"no word of the action from the RCL for "
                           f"{quiet:.1f}s (lease {self.lease:.1f}s)",
                           error=FailureCause.TRANSIENT.value)
        log.warning("RCL silent on %d waiting action(s) past the %.1fs lease: failed",
                    len(expired), self.lease)
        for latch in expired:  # queued for the RCL; repeated if it shows them open later
            self._cancel_abandoned(latch.uuid)
        return [latch.uuid for latch in expired]

    def _cancel_abandoned(self, uuid: str) -> None:
        self._send_control(ActionControl(command=ControlCommand.CANCEL, target=uuid,
                                         target_kind=ControlTarget.ACTION))
        log.info("action %s cancelled: its intention failed on the RCL lease", uuid)

    def latches(self) -> list[Latch]:
        with self._lock:
            return list(self._latches.values())

    def close(self) -> None:
        if self._queries is not None:
            self._queries.shutdown(wait=False, cancel_futures=True)
