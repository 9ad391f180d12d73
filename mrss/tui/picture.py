"""A picture that never lies: what the dashboard asks the system for, and the banner
saying when the picture is no longer current.

On connecting, after a proxy restart (a new greeting from the proxy) and on F5 the
dashboard asks for a full snapshot: the tree (root supervisor), robots and open actions
(RCL), the mind, the world model, and the status of every action it shows open (it may
have ended unseen); asked again after `SNAPSHOT_RETRIES` seconds, as a request may be
lost. Between snapshots it polls the mind (while `auto_mind`), the tree and the world
model, each at its own period. The banner (`models/liveness.py`) says, most serious
first, that the system ended (the root gave up on it; or it went silent after the root
said it was stopping, or with every component stopped), that the bus proxy is not
reachable, or that nothing came for a while. Once ended, the banner stays until a
component starts again (a new run).
"""

from __future__ import annotations

from collections.abc import Callable
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
from mrss.tui.polls import Polls
from mrss.world.topics import WM_REQUEST_TOPIC

SNAPSHOT_RETRIES = (1.0, 3.0)  # seconds after connecting: ask again (a request may be lost)
WATCH_LINK_EVERY = 0.25  # seconds between two looks for a new greeting of the proxy


class Picture:
    """Asks for the picture and says whether it is current.

    `link` carries the requests; `liveness`, `supervision` and `actions` are the app's
    models it reads (and `liveness` the one it ends); `app` gives the timers and shows
    the banner (its `#banner` Static, its `Header`, its `sub_title`)."""

    def __init__(self, app: App[None], link: BusLink, *, liveness: Liveness,
                 supervision: SupervisionModel, actions: ActionsModel, project: str,
                 agent: str, polls: Polls, on_end: Callable[[], None] | None = None) -> None:
        self.app = app
        self.on_end = on_end  # the system ended: what was last heard is no longer so
        self.link = link
        self.liveness = liveness
        self.supervision = supervision
        self.actions = actions
        self.project = project
        self.agent = agent
        self.polls = polls
        self.auto_mind = polls.mind_every > 0  # `a` turns the mind's polling off and on
        self.snapshots_asked = 0
        self.world_asked = 0
        self._welcomes = 0  # the proxy's greetings seen: one more is a (re)connection
        self._system_stopping = False  # the root said it stops everything
        self._banner_shown: str | None = None

    def start(self) -> None:
        """Watch the link for greetings, and poll what has a period."""
        self.app.set_interval(WATCH_LINK_EVERY, self.watch_link)
        if self.polls.mind_every > 0:
            self.app.set_interval(self.polls.mind_every, self._poll_mind)
        if self.polls.tree_every > 0:
            self.app.set_interval(self.polls.tree_every, self._poll_tree)
        if self.polls.world_every > 0:
            self.app.set_interval(self.polls.world_every, self.ask_world)

    # -- requests ---------------------------------------------------------------------------
    def watch_link(self) -> None:
        """A (new) greeting from the proxy: we (re)connected, so ask for the whole picture.

        It also takes what the bus link has waiting, in case the loop missed an edge of
        its socket (it should not; this bounds the cost if it did to a quarter second)."""
        self.link.poll()
        welcomes = self.link.welcomes
        if welcomes != self._welcomes:
            self._welcomes = welcomes
            self.ask_snapshot()
            for delay in SNAPSHOT_RETRIES:
                self.app.set_timer(delay, self.ask_snapshot)

    def ask_snapshot(self) -> None:
        """Ask for everything: the tree (root), robots and open actions (RCL), the mind;
        and the status of every action shown open (it may have ended unseen)."""
        self.snapshots_asked += 1
        requests: list[Message] = [operator.tree_request(), operator.snapshot_request(),
                                   operator.mind_request(self.agent),
                                   operator.questions_request()]
        shown_open = [v.uuid for v in self.actions.newest_first() if not v.terminal]
        if shown_open:
            requests.append(operator.status_query(shown_open))
        for request in requests:
            with suppress(Exception):  # not connected yet: the next ask will do
                self.link.publish(request)
        self.ask_world()

    def ask_world(self) -> None:
        """Ask the world model for its objects (the answer comes as a `DataReply`)."""
        self.world_asked += 1
        with suppress(Exception):  # not connected yet: the next ask will do
            self.link.publish(operator.world_request(self.world_asked), WM_REQUEST_TOPIC)

    def ask_mind(self) -> None:
        """`m`: a mind snapshot now."""
        self.link.publish(operator.mind_request(self.agent))

    def _poll_mind(self) -> None:
        if self.auto_mind:
            with suppress(Exception):
                self.link.publish(operator.mind_request(self.agent))

    def _poll_tree(self) -> None:
        with suppress(Exception):
            self.link.publish(operator.tree_request())

    # -- the banner -------------------------------------------------------------------------
    def system_event(self, event: SupEvent, src: str) -> None:
        """The root giving up on the whole system ends it: the banner keeps the reason.
        A component started by the root afterwards is a new run: the banner clears."""
        if src != ROOT_SRC:
            return
        if event.event is SupEventKind.GIVE_UP and event.detail.get("stops") == "system":
            root = event.supervisor or self.supervision.root or self.project
            self._end(f"{root} gave up: {event.child}: {event.reason}")
            self.show()
        elif (event.event is SupEventKind.STOPPING
              and event.child == (self.supervision.root or event.child)):
            self._system_stopping = True  # its silence, once it falls, is the end
        elif event.event is SupEventKind.START and self.liveness.ended:
            self.liveness.ended = ""
            self._system_stopping = False

    def replayed_back(self) -> None:
        """A replay moved its cursor: whether the system ended is told again from there."""
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

    def banner_text(self) -> str:
        """What the red banner says ("" when the picture is current)."""
        if not self.liveness.ended and self._stopped_quietly():
            root = self.supervision.root or self.project
            self._end(f"system stopped: every component of {root} stopped")
        return self.liveness.banner(self.link.connected)

    def _end(self, why: str) -> None:
        """The system ended: the banner says why, and every robot and component is shown
        as unknown or stopped, not as last heard (`on_end`)."""
        if self.liveness.ended:
            return
        self.liveness.end(why)
        if self.on_end is not None:
            self.on_end()

    def show(self) -> None:
        """Bring the banner, the header's colour and the subtitle up to date."""
        app = self.app
        text = self.banner_text()
        if text == self._banner_shown and app.sub_title:
            subtitle = text or self._connection_text()
            if subtitle != app.sub_title:
                app.sub_title = subtitle
            return
        self._banner_shown = text  # a Static's update lays the screen out again: only on change
        with suppress(NoMatches):
            banner = app.query_one("#banner", Static)
            banner.update(text)
            banner.set_class(bool(text), "-shown")
            app.query_one(Header).set_class(bool(text), "-stale")
        app.sub_title = text or self._connection_text()

    def _connection_text(self) -> str:
        project = f"{self.project} · " if self.project else ""
        # no message count here: a header title that changes every second lays the whole
        # screen out again every second (`mrss bench tui`)
        return f"{project}{self.link.where()}"
