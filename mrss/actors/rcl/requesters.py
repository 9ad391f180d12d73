"""What the RCL owes the components that request actions, across their restarts.

One object of the RCL core (mrss/actors/rcl/core.py), holding what it knows of the
requesters (their incarnations, the orphans they left); it reaches robot actors and
re-sends statuses through the core's `Routes`. Rules:
- a uuid seen before is a duplicate: its last status is sent again (the sender may have
  missed it), and it is not run twice;
- from a newer incarnation of its requester, a known uuid is an adoption: the new
  incarnation waits for the action now, so it is no orphan any more; one its dead
  predecessor suspended is resumed;
- when a requester is seen with a newer incarnation, what its older incarnations left
  open becomes an orphan: it keeps running for `adopt_grace` seconds (suspended ones
  `adopt_grace_suspended`), then is cancelled ("orphaned"); the restarted requester is
  told where every robot stands;
- reconciliation: an `ActionQuery` is answered from the journal, one status per known
  uuid, and for a requester the inventory of what its older incarnations left.
"""

from __future__ import annotations

import logging
from collections.abc import Callable

from mrss.actors.rcl import lifecycle as lc
from mrss.actors.rcl.journal import NOBODY, ActionJournal, JournalEntry, Requester
from mrss.actors.rcl.open_actions import OpenActions, Routes
from mrss.actors.rcl.orphans import Orphans
from mrss.actors.rcl.robot import Control
from mrss.messages import ActionInventory, ActionQuery, ActionState, Message

log = logging.getLogger("mrss.rcl")


class Requesters:
    """Duplicates, adoption, orphans and reconciliation (the rules of the module)."""

    def __init__(self, journal: ActionJournal, publish: Callable[[Message], object],
                 actions: OpenActions, routes: Routes, orphans: Orphans,
                 announce_robots: Callable[[], None]) -> None:
        self.journal, self.publish, self.actions, self.routes = journal, publish, actions, routes
        self.orphans = orphans
        self._announce_robots = announce_robots
        self._incarnations: dict[str, int] = {}  # requester -> its newest incarnation

    def reset(self, incarnations: dict[str, int]) -> None:
        """What the journal says of the requesters' incarnations ({}: a new run)."""
        with self.actions.lock:
            self._incarnations = dict(incarnations)

    def repeat(self, uuid: str, requester: Requester = NOBODY) -> bool:
        """A uuid seen before: re-send its last status (the sender may have missed it).

        From a newer incarnation of the action's requester it is an adoption: the new
        incarnation waits for the action now, so it is no orphan any more; one that its
        dead predecessor suspended is resumed (the new one asks for it to run)."""
        entry = self.journal.get(uuid)
        if entry is None:
            return False
        old = entry.requester
        if (requester.src and requester.src == old.src and requester.inc > old.inc):
            self._adopt(entry, requester)
        else:
            log.info("duplicate action request %s ignored (%s)", uuid,
                     entry.action.state.value)
        self.routes.publish_status(entry.action, repeat=True)
        return True

    def _adopt(self, entry: JournalEntry, requester: Requester) -> None:
        action = entry.action
        log.info("action %s %s adopted by %s incarnation %d (was %d's, %s)", action.uuid,
                 action.literal or action.name, requester.src, requester.inc,
                 entry.requester.inc, action.state.value)
        self.journal.adopt(action.uuid, requester)
        self.orphans.adopted(action.uuid)
        if action.uuid in self.actions:
            self.actions.replace(action.uuid, requester)
            by = lc.SuspendCause.parse(entry.suspended_by)
            if action.state is ActionState.SUSPENDED and by is not None and by.goal_management:
                self.routes.tell(action.robot,
                                 Control(action.uuid, lc.Resume(lc.SuspendCause.AGENT)))

    def saw_incarnation(self, src: str, inc: int) -> list[str]:
        """`src` now runs as incarnation `inc`: cancel what its older incarnations asked for.

        Nobody waits for those actions any more, so no robot should keep working on them.
        Returns the uuids being cancelled.
        """
        with self.actions.lock:
            if inc <= self._incarnations.get(src, -1):
                return []
            first_seen = src not in self._incarnations
            self._incarnations[src] = inc
            orphans = self.actions.matching(
                lambda _u, e: e.requester.src == src and e.requester.inc < inc)
            for uuid, entry in orphans.items():
                grace = self.orphans.add(uuid, entry.state)
                log.warning("action %s is an orphan of %s incarnation %d: cancelled in %.0fs "
                            "unless incarnation %d adopts it", uuid, src, entry.requester.inc,
                            grace, inc)
        if not first_seen:  # a restarted requester: tell it where every robot stands
            self._announce_robots()
        if self.orphans.grace <= 0:
            self.cancel_orphans()
        return sorted(orphans)

    def cancel_orphans(self) -> list[str]:
        """Cancel the orphans whose grace is over (called on a timer); their uuids."""
        with self.actions.lock:
            due = set(self.orphans.take_due())
            entries = self.actions.matching(lambda u, _e: u in due)
        for uuid, entry in entries.items():
            log.warning("cancelling action %s: orphaned by %s incarnation %d, not adopted",
                        uuid, entry.requester.src, entry.requester.inc)
            self.routes.tell(entry.robot, Control(uuid, lc.End(
                ActionState.CANCELLED, lc.EndCause.ORPHANED,
                f"orphaned: {entry.requester.src} incarnation {entry.requester.inc} is gone")))
        return sorted(entries)

    def answer_query(self, query: ActionQuery, requester: Requester = NOBODY) -> int:
        """Reconciliation: re-send the journaled status of each asked uuid, and, for a
        requester, the inventory of what its older incarnations left. Returns how many
        statuses went out."""
        if requester.src:
            self.saw_incarnation(requester.src, requester.inc)
        sent = 0
        for uuid in query.uuids:
            entry = self.journal.get(uuid)
            if entry is not None:
                self.routes.publish_status(entry.action, repeat=True)
                sent += 1
        if query.requester:
            # The asker's incarnation as this node knows it (its proven `inc`: from
            # another node, translated at the border, mrss/bus/border.py), as the
            # journal holds it; the reply repeats the asker's own words.
            asking = requester.inc if requester.src == query.requester and \
                requester.inc > 0 else query.inc
            items = self.orphans.inventory(self.journal, query.requester, asking)
            try:
                self.publish(ActionInventory(requester=query.requester, inc=query.inc,
                                             actions=items))
            except Exception as exc:
                log.error("publishing the inventory for %s failed: %r", query.requester, exc)
        return sent
