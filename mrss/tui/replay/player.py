"""Where a replay is and how it moves: play, pause, speed, seek (no Textual).

The player keeps a cursor on the tape: a time, and the index of the first message not
yet given to the dashboard. `advance` moves the time on by the wall-clock seconds that
passed times the speed, and gives the messages it passed. Seeking sets the cursor
anywhere; the app then rebuilds the dashboard's state for it (`index.py`). The states
and what moves between them are one table, `TRANSITIONS`.
"""

from __future__ import annotations

import functools
from bisect import bisect_right
from collections.abc import Callable, Sequence
from enum import StrEnum

from mrss.messages import Envelope
from mrss.tui.replay.index import Mark
from mrss.tui.replay.tape import Frame

SPEEDS = (0.5, 1.0, 2.0, 5.0, 10.0, 20.0)  # the steps of `<` and `>`
MIN_SPEED, MAX_SPEED = SPEEDS[0], SPEEDS[-1]


class PlayState(StrEnum):
    PLAYING = "playing"
    PAUSED = "paused"
    ENDED = "ended"  # the cursor is past the last message


class PlayCause(StrEnum):
    PLAY = "play"  # space, or the replay starting
    PAUSE = "pause"  # space
    END = "end"  # the cursor passed the last message
    SEEK = "seek"  # a seek before the end


# (state, cause) -> the next state; a pair not in the table leaves the state as it is.
TRANSITIONS: dict[tuple[PlayState, PlayCause], PlayState] = {
    (PlayState.PAUSED, PlayCause.PLAY): PlayState.PLAYING,
    (PlayState.PLAYING, PlayCause.PAUSE): PlayState.PAUSED,
    (PlayState.PLAYING, PlayCause.END): PlayState.ENDED,
    (PlayState.PAUSED, PlayCause.END): PlayState.ENDED,
    (PlayState.ENDED, PlayCause.SEEK): PlayState.PAUSED,
    (PlayState.ENDED, PlayCause.PLAY): PlayState.PLAYING,  # from the start again
}


def speed_in_range(speed: float) -> float:
    """`speed` if it is within [MIN_SPEED, MAX_SPEED]; ValueError saying the range if not."""
    if not MIN_SPEED <= speed <= MAX_SPEED:
        raise ValueError(f"speed {speed:g} is outside {MIN_SPEED:g}x to {MAX_SPEED:g}x")
    return speed


class Player:
    """A cursor on `frames` (time-ordered)."""

    def __init__(self, frames: Sequence[Frame], *, speed: float = 1.0) -> None:
        self.frames = frames
        # where a time falls on the tape: a chunked tape bisects its chunks, then one
        # chunk's frames; a list, the times of all its frames
        bisect_time = getattr(frames, "bisect_time", None)
        if bisect_time is None:
            times = [f.t for f in frames]
            bisect_time = functools.partial(bisect_right, times)
        self._bisect_time: Callable[[float], int] = bisect_time
        self.start = frames[0].t if frames else 0.0
        self.end = frames[-1].t if frames else 0.0
        self.time = self.start
        self.index = 0  # the first message not given yet
        self.speed = speed_in_range(speed)
        self.state = PlayState.PAUSED if frames else PlayState.ENDED

    def _cause(self, cause: PlayCause) -> None:
        self.state = TRANSITIONS.get((self.state, cause), self.state)

    # -- play, pause, speed --------------------------------------------------------------------
    def play(self) -> bool:
        """Start playing; True if it starts over from the beginning (it had ended)."""
        over = self.state is PlayState.ENDED and bool(self.frames)
        self._cause(PlayCause.PLAY)
        return over

    def pause(self) -> None:
        self._cause(PlayCause.PAUSE)

    def faster(self) -> float:
        self.speed = next((s for s in SPEEDS if s > self.speed), MAX_SPEED)
        return self.speed

    def slower(self) -> float:
        self.speed = next((s for s in reversed(SPEEDS) if s < self.speed), MIN_SPEED)
        return self.speed

    def advance(self, seconds: float) -> list[Envelope]:
        """`seconds` of wall-clock time passed: the messages the cursor passed, playing."""
        if self.state is not PlayState.PLAYING:
            return []
        self.time = min(self.end, self.time + seconds * self.speed)
        upto = self._bisect_time(self.time)
        passed = [f.env for f in self.frames[self.index:upto]]
        self.index = upto
        if upto >= len(self.frames):
            self._cause(PlayCause.END)
        return passed

    # -- seeking ----------------------------------------------------------------------------
    def seek_time(self, t: float) -> int:
        """Put the cursor at `t` (clamped to the recording): every message recorded up to
        then is given; the new index."""
        self.time = min(max(t, self.start), self.end)
        return self._seek(self._bisect_time(self.time))

    def seek_mark(self, mark: Mark) -> int:
        """Put the cursor just after the message that made `mark`; the new index."""
        self.time = mark.t
        return self._seek(mark.index + 1)

    def _seek(self, index: int) -> int:
        self.index = index
        self._cause(PlayCause.END if index >= len(self.frames) else PlayCause.SEEK)
        return index

    def now(self) -> float:
        """The recorded time at the cursor (Unix s): the dashboard's clock in a replay."""
        return self.time
