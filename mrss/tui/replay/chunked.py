"""A finished MCAP recording's tape, read a chunk at a time (`mrss tui --replay FILE`).

`ChunkedFrames` is the tape's frames (`tape.Frame`, in time order) without holding them:
the recording is opened by its summary (`IndexedRecording`: the chunk index), and a
frame is decoded when asked for, with its chunk; the last `CACHED_CHUNKS` chunks'
frames are kept. A seek of the replay asks for the frames between a keyframe and the
target (at most `KEYFRAME_EVERY`), so it reads one chunk or two, however large the file.

Which messages a chunk gives, and the world model's answers between them, depend on
what came before (second copies of a message, the objects the writes made): the first
pass over the tape (the replay's index pass iterates it) decides them chunk by chunk
and keeps, per chunk, only what differs from "every message, in log-time order": the
messages left out and the answers put in. Reading a chunk again then gives the same
frames. Until that pass is done, asking for a frame by position finishes it first.

Chunks that overlap in time (the recorder's clock stepped back) would interleave: such
a file, and one without a summary (a recorder killed), is loaded whole instead (`Tape`).
"""

from __future__ import annotations

import bisect
from collections import OrderedDict
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import overload

from mrss.recording.format import RecordingError
from mrss.recording.mcap_seek import ChunkEntries, IndexedRecording
from mrss.tui.replay.tape import Frame, Keep, WorldAnswers

CACHED_CHUNKS = 4  # chunks whose frames are kept decoded


class OverlappingChunks(Exception):
    """The recording's chunks overlap in time: it cannot be read a chunk at a time."""


@dataclass
class _ChunkPlan:
    """What the first pass decided of one chunk: where its frames start on the tape, the
    messages it left out (by their place in the chunk), the answers it put in (after
    the message at that place)."""

    position: int = 0
    count: int = 0
    first_t: float = 0.0
    left_out: set[int] = field(default_factory=set)
    answers: dict[int, Frame] = field(default_factory=dict)


class ChunkedFrames(Sequence[Frame]):
    """The frames of `recording`, decoded chunk by chunk (module doc). `reads` counts
    the chunks read; `left_out` is the tape's count of messages left out, by why."""

    def __init__(self, recording: IndexedRecording, left_out: dict[str, int],
                 on_damage: Callable[[RecordingError], None]) -> None:
        self._recording = recording
        self._left_out = left_out
        self._on_damage = on_damage
        self._plans: list[_ChunkPlan] = []
        self._planned = False
        self._cache: OrderedDict[int, Sequence[Frame]] = OrderedDict()
        self._positions: list[int] = []  # per planned chunk with frames: its position
        self._chunks: list[int] = []  # ... and its index
        self._times: list[float] = []  # ... and its first frame's time
        self._length = 0
        self.reads = 0
        latest = -1
        for i in range(recording.chunks):
            start, end = recording.chunk_span(i)
            if start < latest:
                raise OverlappingChunks(f"chunk {i} starts before chunk {i - 1} ends")
            latest = max(latest, end)

    @property
    def chunks(self) -> int:
        """The recording's chunks."""
        return self._recording.chunks

    @property
    def cached(self) -> int:
        """Chunks whose frames are held now."""
        return len(self._cache)

    # -- the first pass ------------------------------------------------------------------------
    def _plan(self) -> Iterator[Frame]:
        """Read every chunk once, in order, deciding its frames; yield them."""
        for held in (self._plans, self._positions, self._chunks, self._times,
                     self._left_out, self._cache):
            held.clear()  # a pass given up part way is made again from the start
        keep = Keep(self._left_out)
        answers = WorldAnswers()
        position = 0
        for i in range(self._recording.chunks):
            plan = _ChunkPlan(position)
            frames: list[Frame] = []
            try:
                entries = self._entries(i)
            except RecordingError as exc:
                self._on_damage(exc)
                break
            for place, entry in enumerate(entries):
                kept = keep.frames_of_entry(entry)
                if not kept:  # a derived channel's (LocationFix), or left out
                    plan.left_out.add(place)
                    continue
                for frame in kept:  # one an MCAP message: the recorder splits batches
                    frames.append(frame)
                    answer = answers.after(frame, position + len(frames))
                    if answer is not None:
                        frames.append(answer)
                        plan.answers[place] = answer
            plan.count = len(frames)
            plan.first_t = frames[0].t if frames else 0.0
            self._plans.append(plan)
            if frames:
                self._positions.append(position)
                self._chunks.append(i)
                self._times.append(plan.first_t)
            self._remember(i, frames)
            position += len(frames)
            yield from frames
        self._length = position
        self._planned = True

    def finish_plan(self) -> None:
        """Make the first pass now, if it is not made yet."""
        if not self._planned:
            for _ in self._plan():
                pass

    def _entries(self, chunk: int) -> ChunkEntries:
        self.reads += 1
        return self._recording.chunk_entries(chunk)

    # -- frames of a planned chunk -----------------------------------------------------------
    def _remember(self, chunk: int, frames: Sequence[Frame]) -> None:
        self._cache[chunk] = frames
        self._cache.move_to_end(chunk)
        while len(self._cache) > CACHED_CHUNKS:
            self._cache.popitem(last=False)

    def _frames(self, chunk: int) -> Sequence[Frame]:
        frames = self._cache.get(chunk)
        if frames is not None:
            self._cache.move_to_end(chunk)
            return frames
        frames = _LazyChunk(self._entries(chunk), self._plans[chunk])
        self._remember(chunk, frames)
        return frames

    # -- Sequence ---------------------------------------------------------------------------
    def __iter__(self) -> Iterator[Frame]:
        if not self._planned:
            yield from self._plan()
            return
        for chunk in self._chunks:
            yield from self._frames(chunk)

    def __len__(self) -> int:
        self.finish_plan()
        return self._length

    @overload
    def __getitem__(self, index: int) -> Frame: ...

    @overload
    def __getitem__(self, index: slice) -> list[Frame]: ...

    def __getitem__(self, index: int | slice) -> Frame | list[Frame]:
        self.finish_plan()
        if isinstance(index, slice):
            start, stop, step = index.indices(self._length)
            if step != 1:
                return [self[i] for i in range(start, stop, step)]
            return self._between(start, stop)
        if index < 0:
            index += self._length
        if not 0 <= index < self._length:
            raise IndexError(index)
        at = bisect.bisect_right(self._positions, index) - 1
        return self._frames(self._chunks[at])[index - self._positions[at]]

    def _between(self, start: int, stop: int) -> list[Frame]:
        out: list[Frame] = []
        at = max(0, bisect.bisect_right(self._positions, start) - 1)
        while start < stop and at < len(self._chunks):
            base = self._positions[at]
            frames = self._frames(self._chunks[at])
            out.extend(frames[start - base:stop - base])
            start = base + len(frames)
            at += 1
        return out

    def bisect_time(self, t: float) -> int:
        """The position of the first frame after time `t` (`bisect_right` on the times)."""
        self.finish_plan()
        at = bisect.bisect_right(self._times, t) - 1
        if at < 0:
            return 0
        frames = self._frames(self._chunks[at])
        times = frames.times() if isinstance(frames, _LazyChunk) else [f.t for f in frames]
        return self._positions[at] + bisect.bisect_right(times, t)


class _LazyChunk(Sequence[Frame]):
    """A planned chunk's frames, each decoded when first asked for: a seek applies a
    few hundred messages, not the chunk's thousands. Each message the plan kept is one
    frame (the recorder writes each envelope of a batch as a message of its own)."""

    def __init__(self, entries: ChunkEntries, plan: _ChunkPlan) -> None:
        self._entries = entries
        self._slots: list[int | Frame] = []  # a message's place in the chunk, or an answer
        for place in range(len(entries)):
            if place not in plan.left_out:
                self._slots.append(place)
                answer = plan.answers.get(place)
                if answer is not None:
                    self._slots.append(answer)
        self._decoded: dict[int, Frame] = {}
        self._keep = Keep({})  # copies were decided by the first pass: none left here

    def times(self) -> list[float]:
        """Each frame's time, without decoding the messages."""
        log_time = self._entries.log_time
        return [slot.t if isinstance(slot, Frame) else log_time(slot) / 1e9
                for slot in self._slots]

    def __len__(self) -> int:
        return len(self._slots)

    @overload
    def __getitem__(self, index: int) -> Frame: ...

    @overload
    def __getitem__(self, index: slice) -> list[Frame]: ...

    def __getitem__(self, index: int | slice) -> Frame | list[Frame]:
        if isinstance(index, slice):
            return [self[i] for i in range(*index.indices(len(self._slots)))]
        slot = self._slots[index]
        if isinstance(slot, Frame):
            return slot
        frame = self._decoded.get(slot)
        if frame is None:  # the plan kept it: one bus message
            frame = self._decoded[slot] = self._keep.frames_of_entry(self._entries[slot])[0]
        return frame
