"""What each robot would bid from, readable without asking its actor: the bid board.

A round of bidding must not wait for a round trip to every capable robot actor (one
pykka message per actor thread, ~100 thread wake-ups per task at 100 robots), so each
robot actor publishes a small immutable `BidState` (teleop, its open work) whenever it
has handled a message, and the allocator computes every bid on its own thread from it
and the robot's link (position, battery: `bids.link_state`). Rules:
- a state is replaced whole, never changed (a reader sees one or the other);
- an action told to a robot actor (`started`, by the core when the StartAction goes
  out) counts as its work at once, until the actor's own state has it or it ends
  (`ended`): the next round never sees a robot free that was just given a task;
- so does teleop told to it (`teleop`, by the core when the SetTeleop goes out), until
  the actor publishes a state with that teleop: whatever the core has told a robot
  actor, the board knows at once, so a round needs no round trip to confirm a bid;
- a robot without a published state (its actor down, not set up yet) does not bid;
- `states` reads every robot's state under one lock, once per round.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass

from mrss.actors.rcl.allocation.bids import Work


@dataclass(frozen=True)
class BidState:
    """What a robot actor published of itself for bids (immutable)."""

    teleop: bool = False
    work: tuple[Work, ...] = ()

    @property
    def top(self) -> Work | None:
        """Its work that decides whether it is busy: the highest priority, then the
        furthest along (None: idle)."""
        if not self.work:
            return None
        return max(self.work, key=lambda w: (w.priority, w.done))


class BidBoard:
    """robot -> its latest `BidState`, and the actions told to it it has not shown yet."""

    def __init__(self) -> None:
        self._states: dict[str, BidState] = {}
        self._told: dict[str, dict[str, Work]] = {}  # robot -> uuid -> work not seen yet
        self._teleop: dict[str, bool] = {}  # robot -> teleop told, not published yet
        self._lock = threading.Lock()

    def publish(self, robot: str, state: BidState) -> None:
        """The robot actor's own state, after it handled a message."""
        with self._lock:
            self._states[robot] = state
            if self._teleop.get(robot) == state.teleop:
                del self._teleop[robot]
            told = self._told.get(robot)
            if told:
                for w in state.work:
                    told.pop(w.uuid, None)

    def withdraw(self, robot: str, state: BidState) -> None:
        """The robot's actor that published `state` is gone (stopped, crashed): no bids
        until its next incarnation publishes (which may have already)."""
        with self._lock:
            if self._states.get(robot) is state:
                del self._states[robot]

    def started(self, robot: str, work: Work) -> None:
        """An action was told to `robot`'s actor: its work from now on."""
        with self._lock:
            self._told.setdefault(robot, {})[work.uuid] = work

    def teleop(self, robot: str, on: bool) -> None:
        """Teleop on or off was told to `robot`'s actor: its state from now on."""
        with self._lock:
            self._teleop[robot] = on

    def ended(self, uuid: str) -> None:
        """An action ended (or was never started): no robot's work any more."""
        with self._lock:
            for told in self._told.values():
                told.pop(uuid, None)

    def state(self, robot: str) -> BidState | None:
        """The robot's state with what was told to it (None: no actor to bid)."""
        with self._lock:
            return self._merged(robot, self._states.get(robot))

    def states(self) -> dict[str, BidState]:
        """Every robot's state with what was told to it (robots without one left out)."""
        with self._lock:
            states = dict(self._states)
            for robot in set(self._told).union(self._teleop).intersection(states):
                states[robot] = self._merged(robot, states[robot]) or states[robot]
            return states

    def _merged(self, robot: str, state: BidState | None) -> BidState | None:
        told, teleop = self._told.get(robot), self._teleop.get(robot)
        if state is None or (not told and teleop is None):
            return state
        return BidState(state.teleop if teleop is None else teleop,
                        state.work + tuple(told.values()) if told else state.work)
