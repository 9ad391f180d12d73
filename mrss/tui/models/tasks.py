"""The tasks addressed to a role, as the RCL's allocator publishes them: who holds each
and why it won, what a waiting task waits for, and every hand-over.

From `TaskAllocation` (`action.allocation`): an award names the winner and carries the
bids it was decided from (`mrss.messages.bid_reports`), a wait the best excuses, and an
award that hands a task on names the robot that lost it (`lost_from`): a reassignment,
kept in the task's history and returned to the caller (the alert and the log line).
The sentences are made here from those figures, never taken from the message's prose;
an unavailable robot's reason comes from its robot state (`unavailable`). Pure Python.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from mrss.messages import AllocationState, TaskAllocation, WaitReason
from mrss.messages.bid_reports import BidReport

LIMIT = 1000  # tasks kept (the oldest forgotten first)
OTHERS_SHOWN = 3  # runners-up named after the winner (the rest counted)

#: What a waiting task's excuse says, as the reason's phrase.
WAIT_WORDS = {WaitReason.BUSY: "every capable robot is busy",
              WaitReason.BATTERY: "no capable robot has the battery for it",
              WaitReason.UNAVAILABLE: "no capable robot is available",
              WaitReason.NO_BID: "no capable robot answered",
              WaitReason.NONE: "waiting"}


@dataclass(frozen=True)
class Reassignment:
    """A task handed from a lost robot to another."""

    uuid: str
    name: str
    goal: str
    lost_from: str
    robot: str
    ts: float

    @property
    def subject(self) -> str:
        """"cover a1 (3f2a9c1b)": what the alert is about."""
        return task_label(self.name, self.goal, self.uuid)


@dataclass
class TaskView:
    """One task addressed to a role: where it stands, and what that was decided from."""

    uuid: str
    name: str = ""
    goal: str = ""
    state: AllocationState = AllocationState.WAITING
    robot: str = ""  # the holder ("" while it waits)
    wait: WaitReason = WaitReason.NONE
    bids: list[BidReport] = field(default_factory=list)
    bidders: int = 0
    evaluator: str = ""
    capabilities: list[str] = field(default_factory=list)
    near: list[float] = field(default_factory=list)
    holders: list[str] = field(default_factory=list)  # every robot that held it, in order
    reassignments: list[Reassignment] = field(default_factory=list)
    updated: float = 0.0

    @property
    def role(self) -> str:
        """"any(uav, camera) near -35.3630, 149.1650": what it asks for."""
        text = f"any({', '.join(self.capabilities)})"
        if len(self.near) == 2:
            text += f" near {self.near[0]:.4f}, {self.near[1]:.4f}"
        return text

    def why(self, unavailable: Callable[[str], str] = lambda _r: "") -> str:
        """Why it stands where it does, from the bids: "uav3: finish in 42 s, 71 %
        battery after; uav1 busy with priority 5" for an award (after "reassigned from
        uav1: " when it was handed on), "every capable robot is busy: uav1 busy with
        priority 5; ..." for a wait. `unavailable(robot)`: an unavailable robot's reason."""
        shown = [b.describe(unavailable(b.robot) if b.unfit is WaitReason.UNAVAILABLE
                            else "") for b in self.bids[: OTHERS_SHOWN + 1]]
        more = max(self.bidders, len(self.bids)) - len(shown)
        if more > 0:
            shown.append(f"{more} more")
        text = "; ".join(shown)
        if self.state is AllocationState.WAITING:
            return f"{WAIT_WORDS[self.wait]}: {text}" if text else WAIT_WORDS[self.wait]
        if self.reassignments and self.reassignments[-1].robot == self.robot:
            return f"reassigned from {self.reassignments[-1].lost_from}: {text}"
        return text


def task_label(name: str, goal: str, uuid: str) -> str:
    return " ".join(p for p in (name, goal) if p) + f" ({uuid[:8]})"


class TasksModel:
    """Tasks by uuid (the action's uuid: the actions table shows them on its rows)."""

    def __init__(self, limit: int = LIMIT) -> None:
        self.limit = limit
        self.tasks: dict[str, TaskView] = {}

    def apply(self, msg: TaskAllocation, ts: float) -> Reassignment | None:
        """Take one allocation message; the reassignment it tells of, if any."""
        view = self.tasks.get(msg.uuid)
        if view is None:
            view = self.tasks[msg.uuid] = TaskView(msg.uuid)
            if len(self.tasks) > self.limit:
                del self.tasks[next(iter(self.tasks))]
        view.name, view.goal = msg.name or view.name, msg.goal or view.goal
        view.state, view.wait = msg.state, msg.wait
        view.robot = msg.robot if msg.state is AllocationState.AWARDED else ""
        view.bids = [BidReport.from_wire(b) for b in msg.bids]
        view.bidders, view.evaluator = msg.bidders, msg.evaluator
        view.capabilities = list(msg.capabilities) or view.capabilities
        view.near = list(msg.near) or view.near
        view.updated = ts
        if msg.state is not AllocationState.AWARDED:
            return None
        repeat = view.holders[-1:] == [msg.robot]  # the same award heard again
        if not repeat:
            view.holders.append(msg.robot)
        if repeat or not msg.lost_from:
            return None
        change = Reassignment(msg.uuid, view.name, view.goal, msg.lost_from, msg.robot, ts)
        view.reassignments.append(change)
        return change

    def held_by(self, robot: str) -> list[TaskView]:
        """The tasks `robot` holds now (as far as the dashboard heard)."""
        return [t for t in self.tasks.values()
                if t.state is AllocationState.AWARDED and t.robot == robot]

    def waiting(self) -> list[TaskView]:
        return [t for t in self.tasks.values() if t.state is AllocationState.WAITING]
