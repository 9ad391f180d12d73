"""A recording, loaded for the dashboard's replay: its bus messages in time order.

`Tape.load` reads an MCAP recording (what `mrss record` writes) or one of the older MRSS
format, decodes every bus message into the `Envelope` the dashboard's intake takes from a
live bus, and sorts them by the time they were recorded (the recorder's receive time).
Messages recorded as malformed, undecodable ones, ones `mrss replay` had published
(marked replayed: not the system's state then) and second copies of one message (the
reliable channel's, recorded as the message it carries, besides its copy on the plain
topic; its resends) are left out and counted. A file cut or
damaged part way keeps what comes before the damage (`damage` says where).

The world model is not on the bus, only its writes are: after a message that changed
the objects the recording's writes describe (`world.RecordedWorld`), the tape holds the
answer a `wm.list` would have given then, as a `DataReply` to the dashboard, so the map
shows the world as it was. A change of shape is answered at once; objects that only
moved, at most every `WORLD_EVERY` seconds (as the live dashboard polls).
"""

from __future__ import annotations

import tomllib
import weakref
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mrss.bus.wire import message_frames
from mrss.errors import DecodeError
from mrss.messages import DataReply, Envelope, decode
from mrss.recording.files import is_mcap
from mrss.recording.format import RecordedMessage, RecordingError, RecordingReader
from mrss.recording.mcap_reader import McapEntry, McapRecording, recorded_message
from mrss.recording.mcap_seek import IndexedRecording
from mrss.recording.schemas import MALFORMED_SCHEMA, SCHEMA_PREFIX
from mrss.recording.transcode import envelope_of_json
from mrss.tui import operator
from mrss.tui.replay.world import RecordedWorld, WorldChange
from mrss.world.topics import wm_reply_topic

WORLD_EVERY = 2.0  # seconds between two answers for objects that only moved
SEEN_LIMIT = 100_000  # messages kept whose second copies are left out
WORLD_SRC = "worldmodel"
DASHBOARD_SRC = "tui"


@dataclass(frozen=True)
class Frame:
    """One bus message of the recording: when it was recorded (Unix s), and it."""

    t: float
    env: Envelope


@dataclass
class Tape:
    """The recording's messages in time order, and what the file says of its project."""

    frames: Sequence[Frame]  # a list, or a finished MCAP file's ChunkedFrames
    project: str = ""  # the project's name, if the recorder was told it
    project_toml: str = ""  # its project.toml as recorded ("" : not kept)
    _damage: RecordingError | None = field(default=None, repr=False)
    left_out: dict[str, int] = field(default_factory=dict)  # why -> how many

    @property
    def damage(self) -> RecordingError | None:
        """Where the file is damaged (what comes before is on the tape), if it is."""
        finish = getattr(self.frames, "finish_plan", None)
        if finish is not None:
            finish()  # a chunked tape finds damage as it reads its chunks
        return self._damage

    @damage.setter
    def damage(self, damage: RecordingError | None) -> None:
        self._damage = damage

    @property
    def start(self) -> float:
        return self.frames[0].t if self.frames else 0.0

    @property
    def end(self) -> float:
        return self.frames[-1].t if self.frames else 0.0

    def sections(self) -> dict[str, Any]:
        """The recorded project.toml's tables ({} if none or it does not parse)."""
        if not self.project_toml:
            return {}
        try:
            return tomllib.loads(self.project_toml)
        except tomllib.TOMLDecodeError:
            return {}

    @classmethod
    def load(cls, path: Path) -> Tape:
        """Read `path` (OSError if it cannot be read; RecordingError if it is neither
        format; damage further on is kept in `damage`)."""
        indexed = cls._indexed(path)
        if indexed is not None:
            return indexed
        with path.open("rb") as handle:
            if is_mcap(handle):
                recording = McapRecording(handle)
                tape = cls._read(recording.recorded())
                project = recording.metadata.get("project", {})
                tape.project = project.get("name", "")
                tape.project_toml = project.get("project.toml", "")
                return tape
            reader = RecordingReader(handle)
            tape = cls._read(iter(reader))
            return tape

    @classmethod
    def _indexed(cls, path: Path) -> Tape | None:
        """A finished MCAP recording, its frames read a chunk at a time as they are asked
        for (`chunked.py`); None for a file that is to be read whole."""
        from mrss.tui.replay.chunked import ChunkedFrames, OverlappingChunks

        handle = path.open("rb")
        try:
            if not is_mcap(handle):
                handle.close()
                return None
            recording = IndexedRecording(handle)
            tape = cls([])
            tape.frames = ChunkedFrames(recording, tape.left_out, tape._damaged)
            project = recording.metadata("project")
        except (RecordingError, OverlappingChunks):
            handle.close()  # no summary (a recorder killed), or chunks to interleave
            return None
        weakref.finalize(tape, handle.close)
        tape.project = project.get("name", "")
        tape.project_toml = project.get("project.toml", "")
        return tape

    def _damaged(self, damage: RecordingError) -> None:
        self.damage = damage

    @classmethod
    def _read(cls, messages: Any) -> Tape:
        tape = cls([])
        decoded: list[Frame] = []
        keep = Keep(tape.left_out)
        try:
            for message in messages:
                decoded.extend(keep.frames_of(message))
        except RecordingError as exc:
            tape.damage = exc
        decoded.sort(key=lambda f: f.t)  # stable: same-time messages keep file order
        tape.frames = with_world_answers(decoded)
        return tape


class Keep:
    """Which recorded messages a tape keeps, and the count of those left out by why.
    Second copies are known among the last `SEEN_LIMIT` messages kept (a copy comes
    within seconds of its message: the reliable channel's, its resends)."""

    def __init__(self, left_out: dict[str, int]) -> None:
        self.left_out = left_out
        self._seen: dict[tuple[str, str], None] = {}  # in order, oldest first

    def frames_of(self, message: RecordedMessage) -> list[Frame]:
        if message.malformed:
            self._leave_out("malformed when recorded")
            return []
        try:
            envs = [decode(topic, payload) for topic, payload in
                    message_frames(list(message.frames))]
        except DecodeError:
            self._leave_out("undecodable")
            return []
        return self._kept(message.t, envs)

    def frames_of_entry(self, entry: McapEntry) -> list[Frame]:
        """`frames_of` the bus message an MCAP recording's message holds (none for a
        derived channel's, LocationFix, GeoJSON); its JSON read straight into the
        envelope where the fast path vouches for it."""
        if entry.schema.startswith(SCHEMA_PREFIX) and entry.schema != MALFORMED_SCHEMA:
            env = envelope_of_json(entry.topic, entry.data)
            if env is not None:
                return self._kept(entry.log_time / 1e9, [env])
        message = recorded_message(entry)
        return [] if message is None else self.frames_of(message)

    def _kept(self, t: float, envs: list[Envelope]) -> list[Frame]:
        kept = []
        seen = self._seen
        for env in envs:
            key = (env.topic, env.id)
            if env.replayed:
                self._leave_out("published by mrss replay")
            elif key in seen:
                self._leave_out("a copy of a message already recorded")
            else:
                seen[key] = None
                if len(seen) > SEEN_LIMIT:
                    del seen[next(iter(seen))]
                kept.append(Frame(t, env))
        return kept

    def _leave_out(self, why: str) -> None:
        self.left_out[why] = self.left_out.get(why, 0) + 1


class WorldAnswers:
    """The world model's objects as the frames passed so far left them (module doc):
    `after(frame, position)` is the answer to put after `frame`, if one is due."""

    def __init__(self) -> None:
        self.world = RecordedWorld()
        self._answered_at = float("-inf")
        self._moved = False

    def after(self, frame: Frame, position: int) -> Frame | None:
        """`position`: where the answer would go on the tape (it names the answer)."""
        change = self.world.apply(frame.env)
        self._moved = self._moved or change is WorldChange.POSITION
        if change is WorldChange.SHAPE or (
                self._moved and frame.t - self._answered_at >= WORLD_EVERY):
            self._answered_at, self._moved = frame.t, False
            return Frame(frame.t, world_answer(self.world, frame.t, position))
        return None


def with_world_answers(frames: list[Frame]) -> list[Frame]:
    """`frames` with the world model's objects answered after each change (module doc)."""
    answers = WorldAnswers()
    out: list[Frame] = []
    for frame in frames:
        out.append(frame)
        answer = answers.after(frame, len(out))
        if answer is not None:
            out.append(answer)
    return out


def world_answer(world: RecordedWorld, t: float, serial: int) -> Envelope:
    """The world model's answer to the dashboard's `wm.list`, as it would have come at `t`."""
    reply = DataReply(request_id=f"{operator.WORLD_REQUEST_PREFIX}replay-{serial}", ok=True,
                      result=world.listing())
    return Envelope(topic=wm_reply_topic(DASHBOARD_SRC), id=f"replay-world-{serial}", ts=t,
                    src=WORLD_SRC, inc=0, body=reply)
