"""The closed sets on the bus: every field whose values are a fixed list is one of these
enums. msgpack carries the value; the codec gives back the member (mrss.messages.codec)."""

from __future__ import annotations

from enum import StrEnum


class Topic(StrEnum):
    """Topic prefixes; subscribers filter by prefix."""

    PERCEPT = "percept"
    ACTION_REQUEST = "action.request"
    ACTION_ACK = "action.ack"
    ACTION_STATUS = "action.status"
    ACTION_CONTROL = "action.control"
    DL_REQUEST = "dl.request"
    DL_REPLY = "dl.reply"
    ROBOT = "robot."
    SUP = "sup."
    LOG = "log."
    MIND = "mind."
    CTL = "ctl."
    EDGE = "edge."
    AGENT = "agent."
    QUESTION = "question."
    FLEET = "fleet."


class ActionState(StrEnum):
    """States of an action in the RCL (DESIGN.md, "Actions")."""

    PENDING = "pending"
    RUNNING = "running"
    SUSPENDED = "suspended"
    SUCCEEDED = "succeeded"
    FAILED = "failed"
    CANCELLED = "cancelled"

    @property
    def terminal(self) -> bool:
        return self in (ActionState.SUCCEEDED, ActionState.FAILED, ActionState.CANCELLED)


class FailureCause(StrEnum):
    """Why an action failed, as the agent sees it: `-!g[error(Cause)]` (Jason's failure
    reason). "" (no cause) reads `error(action_failed)`, as in Jason."""

    TRANSIENT = "transient"  # a dependency was away (RCL restart, lease, data layer): retry
    LINK_DOWN = "link_down"  # the robot's link was lost
    FAILSAFE = "failsafe"  # the robot lost its controller and went to its safe state
    CANCELLED = "cancelled"  # goal management (operator or agent) cancelled it
    QUARANTINED = "quarantined"  # the robot's actor kept crashing
    REJECTED = "rejected"  # the request was malformed or refused
    ORPHANED = "orphaned"  # its requester's incarnation died and nobody adopted it
    PREEMPTED = "preempted"  # pre-empted longer than the RCL's preempted_timeout
    NODE_DOWN = "node_down"  # the node the robot is reached through was lost
    DECOMMISSIONED = "decommissioned"  # the operator took the robot out of service
    BATTERY_CRITICAL = "battery_critical"  # its battery fell below its critical level
    UNSPECIFIED = ""  # no particular cause: the agent sees error(action_failed)


class ControlCommand(StrEnum):
    """Goal management commands (rcl_goal_management, `mrss send control`)."""

    CANCEL = "cancel"
    SUSPEND = "suspend"
    RESUME = "resume"
    SUCCEED = "succeed"
    FAIL = "fail"


class ControlTarget(StrEnum):
    """What a control command is for: one action, every action of a goal or of a robot."""

    ACTION = "action"
    GOAL = "goal"
    ROBOT = "robot"


class LinkState(StrEnum):
    """A robot's link, as the RCL or a link sees it."""

    UP = "up"
    DOWN = "down"


class SupEventKind(StrEnum):
    """The supervision events on `sup.<event>` (mrss/supervision/events.py, nodes, trees)."""

    START = "start"
    EXIT = "exit"
    RESTART = "restart"
    ESCALATE = "escalate"
    GIVE_UP = "give_up"
    QUARANTINE = "quarantine"
    RELEASE = "release"
    HANG = "hang"
    STOPPING = "stopping"  # the supervisor begins to stop every child (child: itself)
    TREE = "tree"  # the live tree of a supervisor (detail["tree"])
    NODE_DOWN = "node_down"  # a peer node is lost (mrss/supervision/nodes.py)
    NODE_UP = "node_up"


CONTROL_COMMANDS = tuple(c.value for c in ControlCommand)
CONTROL_TARGETS = tuple(t.value for t in ControlTarget)


class EventStatus(StrEnum):
    """What became of an external event at the edge."""

    ACCEPTED = "accepted"    # its percepts went out
    REJECTED = "rejected"    # bad payload: not retried
    FAILED = "failed"        # a dependency stayed down past the retry budget, or a bug
    DUPLICATE = "duplicate"  # a redelivery of an event already handled


class GiveUpReason(StrEnum):
    """Why an agent gave a goal up for good (`GoalGaveUp`, the operator's alert)."""

    BUDGET_EXHAUSTED = "budget_exhausted"  # its retries were used up (the program says so)
    NO_APPLICABLE_PLAN = "no_applicable_plan"  # no plan (or none applicable), no -! plan
    PLAN_FAILED = "plan_failed"  # its plan failed and no -! plan recovered it


class AllocationState(StrEnum):
    """Where a task addressed to a role stands in the RCL's allocation."""

    WAITING = "waiting"  # no capable robot can take it now: awarded once one can
    AWARDED = "awarded"  # one robot won it; its action runs there


class WaitReason(StrEnum):
    """Why a task addressed to a role waits: the best excuse of the robots able to do it."""

    BUSY = "busy"  # every capable robot works at an equal or higher priority
    BATTERY = "battery"  # ... or could not do it and get home with its reserve
    UNAVAILABLE = "unavailable"  # ... or is unavailable (link, quarantine, teleop, node)
    NO_BID = "no_bid"  # ... or did not answer in time
    NONE = ""  # not waiting


class StandDownMode(StrEnum):
    """What the robots of an operator's stand-down by area do (`ctl.stand_down`,
    mrss.actors.rcl.stand_down): stop where they are, or go home; both until lifted."""

    HOLD = "hold"  # every action of the robot suspended; it stops (a copter hovers)
    HOME = "home"  # ... and the robot is sent home by its link (copter RTL, UGV to base)


class QuestionState(StrEnum):
    """Where an operator question of the agent stands (`.ask_operator`, docs/mission.md,
    "Questions to the operator"); the transitions are mrss.actors.reasoner.questions."""

    PENDING = "pending"  # asked, its intention waits for an answer
    ANSWERED = "answered"  # an operator answered (who: `by`)
    TIMED_OUT = "timed_out"  # nobody answered in time: the default answer was taken
    WITHDRAWN = "withdrawn"  # the agent dropped the intention that asked

    @property
    def terminal(self) -> bool:
        return self is not QuestionState.PENDING


class AnswerVerdict(StrEnum):
    """What became of an operator's answer (`AnswerReply`)."""

    ACCEPTED = "accepted"  # it is the question's answer now
    ALREADY = "already"  # the question was already answered, timed out or withdrawn
    UNKNOWN = "unknown"  # no such question
    INVALID = "invalid"  # not one of the question's choices
    REFUSED = "refused"  # the sender may not answer (no credential, or its role may not)
