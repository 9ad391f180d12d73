"""The resource rule against a reference model: random arrivals, priorities, completions,
cancellations, operator suspensions, teleop and link loss (hypothesis, stateful).

The system under test is the real lifecycle (`mrss.actors.rcl.lifecycle.step`) and the real
schedule (`ResourceSchedule`), wired the way the robot actor and the broker wire them,
with one synchronous skill per action that needs one resource for `work` ticks. The
reference model knows only the rule: the resource belongs to the highest-priority action
that wants it (not ended, not suspended by the operator or a teleop), oldest claim first.
"""

from __future__ import annotations

import itertools
from collections import deque
from dataclasses import dataclass, field

from hypothesis import settings
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, invariant, precondition, rule

from mrss.actors.rcl import lifecycle as lc
from mrss.actors.rcl.resources import Decision, Holder, ResourceSchedule
from mrss.api import Action
from mrss.messages import ActionState

R = "airspace"
ROBOTS = ("ugv1", "uav1")


@dataclass
class SimAction:
    """One action as its robot actor keeps it, with its one skill."""

    action: Action
    life: lc.Lifecycle
    work: int
    skill: str = ""  # "", "waiting", "holding"
    run: int = 0
    ends: list[ActionState] = field(default_factory=list)

    @property
    def token(self) -> str:
        return f"{self.action.uuid}/{self.run}/0"


@dataclass
class Model:
    """The reference: who wants the resource, how old each claim is, progress, ends."""

    priority: dict[str, int] = field(default_factory=dict)
    robot: dict[str, str] = field(default_factory=dict)
    work: dict[str, int] = field(default_factory=dict)
    age: dict[str, int] = field(default_factory=dict)  # only for actions that want it
    progress: dict[str, int] = field(default_factory=dict)
    operator: set[str] = field(default_factory=set)  # suspended by the operator
    teleop: set[str] = field(default_factory=set)  # robots in teleop
    ended: dict[str, ActionState] = field(default_factory=dict)
    clock: itertools.count[int] = field(default_factory=itertools.count)

    def wants(self, uuid: str) -> bool:
        return (uuid not in self.ended and uuid not in self.operator
                and self.robot[uuid] not in self.teleop)

    def refresh(self, order: list[str]) -> None:
        """A claim starts when an action starts wanting; it ends when it stops wanting."""
        for uuid in order:
            if self.wants(uuid) and uuid not in self.age:
                self.age[uuid] = next(self.clock)
            elif not self.wants(uuid):
                self.age.pop(uuid, None)

    def holder(self) -> str | None:
        if not self.age:
            return None
        return min(self.age, key=lambda u: (-self.priority[u], self.age[u]))


class SchedulerMachine(RuleBasedStateMachine):
    def __init__(self) -> None:
        super().__init__()
        self.schedule = ResourceSchedule()
        self.actions: dict[str, SimAction] = {}
        self.teleop: set[str] = set()
        self.mailbox: deque[tuple[str, lc.Event]] = deque()
        self.model = Model()
        self.ids = itertools.count()

    # -- the robot actor, synchronously -----------------------------------------------
    def tell(self, uuid: str, event: lc.Event) -> None:
        self.mailbox.append((uuid, event))

    def pump(self) -> None:
        while self.mailbox:
            uuid, event = self.mailbox.popleft()
            self.feed(self.actions[uuid], event)

    def feed(self, a: SimAction, event: lc.Event) -> None:
        if a.life.phase.terminal:
            return  # the actor forgot it; late messages are dropped
        a.life, effects = lc.step(a.life, event)
        for effect in effects:
            if isinstance(effect, lc.Run):
                a.run += 1
                if a.action.state is not ActionState.RUNNING:
                    a.action.transition(ActionState.RUNNING, effect.reason)
                a.skill = "waiting"
                self.apply(self.schedule.request(R, Holder(a.token, a.action.uuid,
                                                           a.action.priority)))
            elif isinstance(effect, lc.Interrupt):
                if a.skill:
                    a.skill = ""
                    self.apply(self.schedule.release_token(a.token))
                    self.tell(a.action.uuid, lc.SkillEnded(all_ended=True))
                else:
                    self.feed(a, lc.Stopped())
                    return
            elif isinstance(effect, lc.CheckStatus):
                done = int(a.action.progress.get("done", 0)) >= a.work  # type: ignore[arg-type]
                self.feed(a, lc.Verdict(ActionState.SUCCEEDED if done else None,
                                        all_ended=not a.skill))
                return
            elif isinstance(effect, lc.ReleaseResources):
                self.apply(self.schedule.forget(a.action.uuid))
            elif isinstance(effect, lc.Publish):
                a.action.transition(effect.state, effect.reason, effect.cause)
                if effect.state.terminal:
                    a.ends.append(effect.state)
                    self.apply(self.schedule.forget(a.action.uuid))

    def apply(self, decision: Decision) -> None:
        """What the broker does with a decision: wake granted skills, call back."""
        for token in decision.granted:
            uuid = token.split("/")[0]
            a = self.actions[uuid]
            assert a.token == token and a.skill == "waiting", (token, a)
            a.skill = "holding"
        for uuid, _ in decision.preempt:
            self.tell(uuid, lc.Suspend(lc.SuspendCause.PREEMPTED, "pre-empted"))
        for uuid, _ in decision.resume:
            self.tell(uuid, lc.Resume(lc.SuspendCause.PREEMPTED))

    def open_actions(self) -> list[str]:
        return [u for u, a in self.actions.items() if not a.life.phase.terminal]

    # -- rules ------------------------------------------------------------------------
    @rule(priority=st.integers(0, 3), robot=st.sampled_from(ROBOTS), work=st.integers(1, 3))
    def arrive(self, priority: int, robot: str, work: int) -> None:
        uuid = f"a{next(self.ids)}"
        self.model.priority[uuid], self.model.robot[uuid] = priority, robot
        self.model.work[uuid], self.model.progress[uuid] = work, 0
        self.model.refresh([uuid])
        action = Action(uuid=uuid, name="hold", robot=robot, priority=priority)
        self.actions[uuid] = SimAction(action, lc.Lifecycle(lc.Phase.PENDING), work)
        self.feed(self.actions[uuid], lc.Accept(robot in self.teleop))
        self.pump()

    @rule()
    def tick(self) -> None:
        """The holder's skill makes one step of progress; at `work` it succeeds."""
        holder = next((a for a in self.actions.values() if a.skill == "holding"), None)
        expected = self.model.holder()
        assert (holder.action.uuid if holder else None) == expected
        if holder is None or expected is None:
            return
        done = int(holder.action.progress.get("done", 0)) + 1  # type: ignore[arg-type]
        holder.action.progress["done"] = done
        self.model.progress[expected] += 1
        if done >= holder.work:
            holder.skill = ""
            self.apply(self.schedule.release_token(holder.token))
            self.tell(holder.action.uuid, lc.SkillEnded(all_ended=True))
            self.model.ended[expected] = ActionState.SUCCEEDED
            self.model.refresh([expected])
        self.pump()

    @precondition(lambda self: bool(self.open_actions()))
    @rule(data=st.data(), command=st.sampled_from(["cancel", "suspend", "resume"]))
    def operator(self, data: st.DataObject, command: str) -> None:
        uuid = data.draw(st.sampled_from(self.open_actions()))
        by = lc.SuspendCause.OPERATOR
        if command == "cancel":
            self.tell(uuid, lc.End(ActionState.CANCELLED, lc.EndCause.OPERATOR))
            self.model.ended[uuid] = ActionState.CANCELLED
        elif command == "suspend":
            self.tell(uuid, lc.Suspend(by))
            self.model.operator.add(uuid)
        else:
            self.tell(uuid, lc.Resume(by, self.actions[uuid].action.robot in self.teleop))
            self.model.operator.discard(uuid)
        self.model.refresh([uuid])
        self.pump()

    @rule(robot=st.sampled_from(ROBOTS), on=st.booleans())
    def teleop_switch(self, robot: str, on: bool) -> None:
        if on == (robot in self.teleop):
            return
        (self.teleop.add if on else self.teleop.discard)(robot)
        (self.model.teleop.add if on else self.model.teleop.discard)(robot)
        mine = [u for u in self.open_actions() if self.actions[u].action.robot == robot]
        for uuid in mine:
            self.tell(uuid, lc.Suspend(lc.SuspendCause.TELEOP, "robot in teleop") if on
                      else lc.Resume(lc.SuspendCause.TELEOP, teleop=False))
        self.model.refresh(mine)
        self.pump()

    @rule(robot=st.sampled_from(ROBOTS))
    def link_lost(self, robot: str) -> None:
        mine = [u for u in self.open_actions() if self.actions[u].action.robot == robot]
        for uuid in mine:
            self.tell(uuid, lc.End(ActionState.FAILED, lc.EndCause.LINK_LOST, "link lost"))
            self.model.ended[uuid] = ActionState.FAILED
        self.model.refresh(mine)
        self.pump()

    # -- invariants (checked after every rule, once the mailbox is empty) ---------------
    @invariant()
    def the_holder_is_the_highest_priority_runnable_candidate(self) -> None:
        holding = [u for u, a in self.actions.items() if a.skill == "holding"]
        expected = self.model.holder()
        assert holding == ([expected] if expected else []), (holding, expected,
                                                             self.model.age)
        assert self.schedule.holders(R) == set(holding)

    @invariant()
    def no_action_is_both_running_and_suspended(self) -> None:
        for a in self.actions.values():
            phase = a.life.phase
            assert phase is not lc.Phase.STOPPING and phase is not lc.Phase.PENDING
            assert a.action.state.value == phase.value
            assert (a.life.suspended_by is not None) == (phase is lc.Phase.SUSPENDED)
            if a.skill:
                assert phase is lc.Phase.RUNNING, a

    @invariant()
    def every_action_ends_in_exactly_one_terminal_state(self) -> None:
        for uuid, a in self.actions.items():
            ended = self.model.ended.get(uuid)
            assert a.ends == ([ended] if ended else []), (uuid, a.ends, ended)

    @invariant()
    def progress_is_never_lost_across_suspension(self) -> None:
        for uuid, a in self.actions.items():
            assert a.action.progress.get("done", 0) == self.model.progress[uuid]


SchedulerMachine.TestCase.settings = settings(max_examples=150, stateful_step_count=30,
                                              deadline=None)
test_scheduler_serves_the_highest_priority = SchedulerMachine.TestCase


def test_the_resource_rule_is_stated_identically_in_the_docs_the_code_and_the_template(
        ) -> None:
    import re
    from pathlib import Path

    from mrss.actors.rcl import resources
    root = Path(__file__).resolve().parents[2]
    doc = (root / "docs" / "rcl.md").read_text(encoding="utf-8")
    found = re.search(r"<!-- resource-rule -->\n(.*?)<!-- /resource-rule -->", doc, re.S)
    assert found, "docs/rcl.md lacks the <!-- resource-rule --> block"
    rule_text = " ".join(found.group(1).split())
    assert rule_text.startswith("A resource is held by one action")

    def flat(text: str) -> str:
        return " ".join(re.sub(r"^\s*(//|#)", "", line) for line in text.splitlines())

    for where in (resources.__doc__ or "",
                  (root / "projects/template/agent.asl").read_text(encoding="utf-8"),
                  (root / "projects/template/rcl.py").read_text(encoding="utf-8")):
        assert rule_text in " ".join(flat(where).split()), where[:200]
