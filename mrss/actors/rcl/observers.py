"""What the RCL tells those who watch it: progress, a full snapshot, its actor tree, and
the state of an action.

One object of the RCL core (mrss/actors/rcl/core.py), owning the progress feed and the
board of the skills' latest plans; it re-sends statuses through the core's `Routes`.
Rules:
- progress goes out as repeat statuses (`ProgressFeed`: at most every `progress_every`
  seconds per action), under the lock that covers a transition's publication, and only
  for an action whose journaled state is the one last published: a progress status is
  never out after its action's terminal status, nor before a transition journaled;
- a snapshot (an observer's `Command("snapshot")`) re-sends every robot's state, every
  open action's status, the latest plan of each robot's skills, and the tree of the
  robot actors (`sup.tree` with scope "component"): a dashboard that attaches late
  misses nothing.
"""

from __future__ import annotations

from collections.abc import Callable

import pykka

from mrss.actors.rcl.journal import ActionJournal
from mrss.actors.rcl.layer import RobotCommLayer
from mrss.actors.rcl.open_actions import OpenActions, Routes
from mrss.actors.rcl.progress_feed import ProgressFeed
from mrss.messages import ActionState, Message, SupEvent
from mrss.messages.plans import PlanBoard
from mrss.runtime.remote import TREE_EVENT
from mrss.supervision import ActorSupervisor


class ObserverReports:
    """Progress, snapshot and state queries (the rules of the module)."""

    def __init__(self, layer: RobotCommLayer, journal: ActionJournal,
                 publish: Callable[[Message], object], actions: OpenActions, routes: Routes,
                 progress: ProgressFeed, announce_robots: Callable[[], None],
                 robots: Callable[[], pykka.ActorRef[ActorSupervisor] | None]) -> None:
        self.layer, self.journal, self.publish = layer, journal, publish
        self.actions, self.routes, self.progress = actions, routes, progress
        self.plans = PlanBoard()  # skills' latest plans, for the snapshot
        self._announce_robots = announce_robots
        self._robots = robots

    def publish_progress(self) -> int:
        """Publish the progress that is due (`ProgressFeed`) as repeat statuses; how many.

        Under the lock that also covers a transition's publication, and only for an action
        whose journaled state is the one last published: a progress status never goes out
        after its action's terminal status, nor before a transition already journaled."""
        sent = 0
        with self.actions.lock:
            for uuid, progress in self.progress.take_due().items():
                known, entry = self.actions.get(uuid), self.journal.get(uuid)
                if known is None or entry is None or entry.action.state is not known.state:
                    continue
                action = entry.action
                action.progress = progress
                self.routes.publish_status(action, repeat=True)
                sent += 1
        return sent

    def snapshot(self) -> int:
        """Answer an observer's `Command("snapshot")`: every robot's state, every open
        action's current status (`repeat`, with name and goal), the latest plan its
        skills sent and the tree of its robot actors (`sup.tree`), so a dashboard that
        attaches late misses nothing. Returns how many statuses went out."""
        self._announce_robots()
        self._publish_actor_tree()
        for robot, record in self.plans.current():
            self.layer.publish_data(robot, record)
        with self.actions.lock:
            entries = [e for e in self.journal.open_actions() if e.action.uuid in self.actions]
            for entry in entries:
                self.routes.publish_status(entry.action, repeat=True)
        return len(entries)

    def _publish_actor_tree(self) -> None:
        robots = self._robots()
        if robots is None:
            return
        try:
            tree = robots.proxy().tree().get(timeout=1.0)
        except (pykka.ActorDeadError, pykka.Timeout):
            return  # stopping or busy: the actors' own events tell the rest
        # scope "component": the tree of a supervisor inside this component, not the root's
        self.publish(SupEvent(event=TREE_EVENT, child=tree.id,
                              detail={"tree": tree.to_dict(), "scope": "component"}))

    def state(self, uuid: str) -> ActionState | None:
        """The last journaled state of an action (None if never seen)."""
        entry = self.journal.get(uuid)
        return entry.action.state if entry else None

    def active(self) -> dict[str, ActionState]:
        """Every non-terminal action and its state."""
        return self.actions.states()

