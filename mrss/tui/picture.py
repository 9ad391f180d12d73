"""A picture that never lies: the whole picture asked for on (re)connecting, and the
banner saying when it is no longer current. A base of `MrssApp`.

On connecting, after a proxy restart (a new greeting from the proxy) and on F5 the app
asks for a full snapshot: the tree (root supervisor), robots and open actions (RCL), the
mind, the world model, and the status of every action it shows open (it may have ended
unseen); asked again after `SNAPSHOT_RETRIES` seconds, as a request may be lost. The
banner (`models/liveness.py`) says, most serious first, that the system ended (the root
gave up on it; or it went silent after the root said it was stopping, or with every
component stopped), that the bus proxy is not reachable, or that nothing came for a
while. Once ended, the banner stays until a component starts again (a new run).
"""

from __future__ import annotations

from contextlib import suppress

from textual.app import App
from textual.css.query import NoMatches
from textual.widgets import Header, Static

from mrss.messages import Message, SupEvent, SupEventKind
from mrss.tui import operator
from mrss.tui.buslink import BusLink
from mrss.tui.models.actions import ActionsModel
from mrss.tui.models.liveness import Liveness
from mrss.tui.models.supervision import ROOT_SRC, SupervisionModel

SNAPSHOT_RETRIES = (1.0, 3.0)  # seconds after connecting: ask again (a request may be lost)


class TruthfulPicture(App[None]):
    """Snapshots on (re)connecting and the liveness banner; the models are the app's."""

    actions: ActionsModel
    supervision: SupervisionModel
    liveness: Liveness
    link: BusLink
    project: str
    agent: str
    snapshots_asked: int
    _welcomes: int
    _banner_shown: str | None
    _system_stopping: bool

    def ask_world(self) -> None:
        raise NotImplementedError

    def _system_end(self, event: SupEvent, src: str) -> None:
        """The root giving up on the whole system ends it: the banner keeps the reason.
        A component started by the root afterwards is a new run: the banner clears."""
        if src != ROOT_SRC:
            return
        if event.event is SupEventKind.GIVE_UP and event.detail.get("stops") == "system":
            root = event.supervisor or self.supervision.root or self.project
            self.liveness.end(f"{root} gave up: {event.child}: {event.reason}")
            self._show_liveness()
        elif event.event is SupEventKind.STOPPING and event.child == (self.supervision.root
                                                            or event.child):
            self._system_stopping = True  # its silence, once it falls, is the end
        elif event.event is SupEventKind.START and self.liveness.ended:
            self.liveness.ended = ""
            self._system_stopping = False

    def _stopped_quietly(self) -> bool:
        """Silent, after the root said it was stopping, or with every component of the
        root stopped (but perhaps the bus proxy, which cannot tell its own end over the
        bus): the system was stopped."""
        if self.liveness.silence() < self.liveness.stale_after:
            return False
        if self._system_stopping:
            return True  # the root said so (the last exits may not have come through)
        root = self.supervision.root or self.project
        states = [n.state for n in self.supervision.nodes.values() if n.parent == root]
        down = sum(state in ("stopped", "exited", "gave up") for state in states)
        return "stopped" in states and down >= len(states) - 1

    def _watch_link(self) -> None:
        """A (new) greeting from the proxy: we (re)connected, so ask for the whole picture.

        It also takes what the bus link has waiting, in case the loop missed an edge of
        its socket (it should not; this bounds the cost if it did to a quarter second)."""
        self.link.poll()
        welcomes = self.link.welcomes
        if welcomes != self._welcomes:
            self._welcomes = welcomes
            self.ask_snapshot()
            for delay in SNAPSHOT_RETRIES:
                self.set_timer(delay, self.ask_snapshot)

    def ask_snapshot(self) -> None:
        """Ask for everything: the tree (root), robots and open actions (RCL), the mind;
        and the status of every action shown open (it may have ended unseen)."""
        self.snapshots_asked += 1
        requests: list[Message] = [operator.tree_request(), operator.snapshot_request(),
                                   operator.mind_request(self.agent)]
        shown_open = [v.uuid for v in self.actions.newest_first() if not v.terminal]
        if shown_open:
            requests.append(operator.status_query(shown_open))
        for request in requests:
            with suppress(Exception):  # not connected yet: the next ask will do
                self.link.publish(request)
        self.ask_world()

    def banner_text(self) -> str:
        """What the red banner says ("" when the picture is current)."""
        if not self.liveness.ended and self._stopped_quietly():
            root = self.supervision.root or self.project
            self.liveness.end(f"system stopped: every component of {root} stopped")
        return self.liveness.banner(self.link.connected)

    def _show_liveness(self) -> None:
        text = self.banner_text()
        if text == self._banner_shown and self.sub_title:
            subtitle = text or self._connection_text()
            if subtitle != self.sub_title:
                self.sub_title = subtitle
            return
        self._banner_shown = text  # a Static's update lays the screen out again: only on change
        with suppress(NoMatches):
            banner = self.query_one("#banner", Static)
            banner.update(text)
            banner.set_class(bool(text), "-shown")
            self.query_one(Header).set_class(bool(text), "-stale")
        self.sub_title = text or self._connection_text()

    def _connection_text(self) -> str:
        project = f"{self.project} · " if self.project else ""
        # no message count here: a header title that changes every second lays the whole
        # screen out again every second (`mrss bench tui`)
        return f"{project}connected · {self.link.endpoints.backend}"

