"""ReplayApp: the dashboard driven by a recording (`mrss tui --replay FILE`).

The whole dashboard of `MrssApp`, unchanged, with a `ReplayLink` where the bus link
would be: the player feeds it the recorded messages as the cursor passes them, and the
app drains them into its intake as it would a live bus's. Under the panels a
`TimelineBar`; keys: space play/pause, `<` `>` speed (0.5x to 20x), `,` `.` 10 s back
or on, `T` a time, `F` `R` `W` the next failed action, restart or alert (a click on the
bar seeks there too). A seek, back or forward, rebuilds the models from the keyframe
before the target and the messages between (`index.py`), then redraws every panel.
The replay is read-only: every control is refused as in `--readonly`.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterator
from contextlib import suppress
from typing import Any, ClassVar

from textual.app import ComposeResult
from textual.binding import Binding, BindingType
from textual.css.query import NoMatches
from textual.widgets import Footer

from mrss.messages import Envelope, MindSnapshot
from mrss.tui.app import MrssApp
from mrss.tui.intake import BusIntake, Mind
from mrss.tui.redraws import SCHEDULED
from mrss.tui.replay.index import (
    KEYFRAME_EVERY,
    TOPICS_WINDOW,
    MarkKind,
    ReplayIndex,
    fresh_models,
    recount_topics,
    restore,
)
from mrss.tui.replay.link import NO_BUS, ReplayLink
from mrss.tui.replay.player import Player, PlayState, speed_in_range
from mrss.tui.replay.seek_form import SeekScreen
from mrss.tui.replay.tape import Tape
from mrss.tui.widgets.alerts_strip import AlertsStrip
from mrss.tui.widgets.log_pane import MAX_LINES, LogPane
from mrss.tui.widgets.mind_inspector import MindInspector
from mrss.tui.widgets.timeline_bar import TimelineBar, clock_text

STEP_EVERY = 0.1  # seconds of wall-clock time between two moves of a playing cursor
SKIP = 10.0  # seconds `,` and `.` move the cursor
LOG_SHOWN = 100  # log lines drawn after a seek (the pane keeps all; `L` lists them)


class ReplayApp(MrssApp):
    """The dashboard over a recording; see the module docstring."""

    CSS = MrssApp.CSS + """
    #timeline { dock: bottom; }
    """
    BINDINGS: ClassVar[list[BindingType]] = [
        *MrssApp.BINDINGS,
        Binding("space", "play_pause", "Play/pause"),
        Binding("less_than_sign", "slower", "Slower"),
        Binding("greater_than_sign", "faster", "Faster"),
        Binding("comma", "skip(-1)", "Back 10 s", show=False),
        Binding("full_stop", "skip(1)", "On 10 s", show=False),
        Binding("T", "seek_time", "Seek to time"),
        Binding("F", "next_mark('action failed')", "Next failed action", show=False),
        Binding("R", "next_mark('restart')", "Next restart", show=False),
        Binding("W", "next_mark('alert')", "Next alert", show=False),
    ]

    def __init__(self, tape: Tape, *, name: str, speed: float = 1.0, play: bool = True,
                 keyframe_every: int = KEYFRAME_EVERY, **kwargs: Any) -> None:
        speed_in_range(speed)
        link = ReplayLink(f"replay of {name}")
        super().__init__(NO_BUS, link=link, readonly=True, clock=self._recorded_now,
                         mind_every=0, tree_every=0, world_every=0,
                         stale_after=math.inf, **kwargs)
        self.tape = tape
        self.replay_link = link
        self.autoplay = play
        self.seeks = 0  # rebuilds done (tests wait on it)
        shadow = BusIntake(self, ReplayLink(name), fresh_models(self.intake.models),
                           agent=self.intake.agent, min_refresh=0.0,
                           deliver=lambda _: None, system_event=lambda _e, _s: None)
        # the index pass first: a chunked tape decides its frames in it (one read of the
        # file), which the player's look at its ends would otherwise make a pass of its own
        self.index = ReplayIndex.build(tape.frames, shadow, every=keyframe_every)
        self.player = Player(tape.frames, speed=speed)
        self.topics.clock = self.player.now  # the Messages screen's rates: per recorded s
        self._last_step = time.monotonic()

    def _recorded_now(self) -> float:
        """The dashboard's clock: the recorded time at the cursor."""
        return self.player.now()

    def compose(self) -> ComposeResult:
        for widget in super().compose():
            if isinstance(widget, Footer):
                yield TimelineBar(self.player, self.index.marks, id="timeline")
            yield widget

    def on_mount(self) -> None:
        super().on_mount()
        self.title = f"{self.TITLE} (replay)"
        self.set_interval(STEP_EVERY, self.step)
        if self.autoplay:
            self.player.play()
        self._last_step = time.monotonic()
        self.timeline.show()

    @property
    def timeline(self) -> TimelineBar:
        return self.query_one(TimelineBar)

    # -- playing ----------------------------------------------------------------------------
    def step(self) -> None:
        """Move a playing cursor on by the time that passed; feed what it passed."""
        now = time.monotonic()
        passed, self._last_step = now - self._last_step, now
        if self.player.state is not PlayState.PLAYING:
            return
        self.replay_link.feed(self.player.advance(passed))
        with suppress(NoMatches):
            self.timeline.show()

    def action_play_pause(self) -> None:
        if self.player.state is PlayState.PLAYING:
            self.player.pause()
        elif self.player.play():
            self.seek_to(self.player.start)  # it had ended: from the start again
        self._last_step = time.monotonic()
        self.timeline.show()

    def action_faster(self) -> None:
        self.say(f"replay at {self.player.faster():g}x")
        self.timeline.show()

    def action_slower(self) -> None:
        self.say(f"replay at {self.player.slower():g}x")
        self.timeline.show()

    # -- seeking ----------------------------------------------------------------------------
    def action_skip(self, direction: int) -> None:
        self.seek_to(self.player.time + direction * SKIP)

    def action_seek_time(self) -> None:
        def chosen(target: float | None) -> None:
            if target is not None:
                self.seek_to(target)

        self.push_screen(SeekScreen(start=self.player.start, cursor=self.player.time), chosen)

    def action_next_mark(self, kind: str) -> None:
        wanted = MarkKind(kind)
        mark = self.index.next_mark(wanted, self.player.index)
        if mark is None:
            self.say(f"no {wanted.value} after {clock_text(self.player.time - self.player.start)}")
            return
        self.player.seek_mark(mark)
        self.rebuild()
        self.say(f"{wanted.value} at {clock_text(mark.t - self.player.start)}: {mark.text}")

    def on_timeline_bar_seek(self, event: TimelineBar.Seek) -> None:
        self.seek_to(event.t)

    def seek_to(self, t: float) -> None:
        """Put the cursor at recorded time `t` and show the dashboard as it was then."""
        self.player.seek_time(t)
        self.rebuild()

    def rebuild(self) -> None:
        """The models as they were at the cursor: from the keyframe before it, then the
        messages between, in one go, without drawing; then every panel is drawn."""
        self.replay_link.discard()
        target = self.player.index
        keyframe = self.index.keyframe_before(target)
        self.picture.replayed_back()
        models = self.intake.models
        restore(models, keyframe.state)
        recount_topics(models, self.tape.frames[max(0, target - TOPICS_WINDOW):target])
        mind = keyframe.mind
        envelopes = [f.env for f in self.tape.frames[keyframe.index:target]]
        for batch in _up_to_each_mind(envelopes):
            mind = self.intake.take(batch).mind or mind
        self.seeks += 1
        self._last_step = time.monotonic()
        with suppress(NoMatches):  # the panels are gone: the app is closing
            self._show_all(mind, target)

    def _show_all(self, mind: Mind | None, target: int) -> None:
        self.redraws.changed(SCHEDULED)
        inspector = self.query_one(MindInspector)
        inspector.forget()
        if mind is not None:
            inspector.show_snapshot(mind.snapshot, mind.ts, mind.inc)
        self.query_one(AlertsStrip).show_alerts()
        self.query_one(LogPane).replace(self.index.lines_before(target, MAX_LINES),
                                        shown_most=LOG_SHOWN)
        self.timeline.show()


def _up_to_each_mind(envelopes: list[Envelope]) -> Iterator[list[Envelope]]:
    """`envelopes` in batches each ending at a mind snapshot (the goals are read from
    each snapshot, as the live dashboard reads each one it gets)."""
    start = 0
    for i, env in enumerate(envelopes):
        if isinstance(env.body, MindSnapshot):
            yield envelopes[start:i + 1]
            start = i + 1
    if start < len(envelopes):
        yield envelopes[start:]
