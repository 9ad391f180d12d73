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
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mrss.bus.wire import message_frames
from mrss.errors import DecodeError
from mrss.messages import DataReply, Envelope, decode
from mrss.recording.files import is_mcap
from mrss.recording.format import RecordedMessage, RecordingError, RecordingReader
from mrss.recording.mcap_reader import McapRecording
from mrss.tui import operator
from mrss.tui.replay.world import RecordedWorld, WorldChange
from mrss.world.topics import wm_reply_topic

WORLD_EVERY = 2.0  # seconds between two answers for objects that only moved
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

    frames: list[Frame]
    project: str = ""  # the project's name, if the recorder was told it
    project_toml: str = ""  # its project.toml as recorded ("" : not kept)
    damage: RecordingError | None = None
    left_out: dict[str, int] = field(default_factory=dict)  # why -> how many

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
    def _read(cls, messages: Any) -> Tape:
        tape = cls([])
        decoded: list[Frame] = []
        seen: set[tuple[str, str]] = set()
        try:
            for message in messages:
                decoded.extend(tape._frames_of(message, seen))
        except RecordingError as exc:
            tape.damage = exc
        decoded.sort(key=lambda f: f.t)  # stable: same-time messages keep file order
        tape.frames = with_world_answers(decoded)
        return tape

    def _frames_of(self, message: RecordedMessage, seen: set[tuple[str, str]]
                   ) -> list[Frame]:
        if message.malformed:
            self._leave_out("malformed when recorded")
            return []
        try:
            envs = [decode(topic, payload) for topic, payload in
                    message_frames(list(message.frames))]
        except DecodeError:
            self._leave_out("undecodable")
            return []
        kept = []
        for env in envs:
            if env.replayed:
                self._leave_out("published by mrss replay")
            elif (env.topic, env.id) in seen:
                self._leave_out("a copy of a message already recorded")
            else:
                seen.add((env.topic, env.id))
                kept.append(Frame(message.t, env))
        return kept

    def _leave_out(self, why: str) -> None:
        self.left_out[why] = self.left_out.get(why, 0) + 1


def with_world_answers(frames: list[Frame]) -> list[Frame]:
    """`frames` with the world model's objects answered after each change (module doc)."""
    world = RecordedWorld()
    out: list[Frame] = []
    answered_at = float("-inf")
    moved = False
    for frame in frames:
        out.append(frame)
        change = world.apply(frame.env)
        moved = moved or change is WorldChange.POSITION
        if change is WorldChange.SHAPE or (moved and frame.t - answered_at >= WORLD_EVERY):
            out.append(Frame(frame.t, world_answer(world, frame.t, len(out))))
            answered_at, moved = frame.t, False
    return out


def world_answer(world: RecordedWorld, t: float, serial: int) -> Envelope:
    """The world model's answer to the dashboard's `wm.list`, as it would have come at `t`."""
    reply = DataReply(request_id=f"{operator.WORLD_REQUEST_PREFIX}replay-{serial}", ok=True,
                      result=world.listing())
    return Envelope(topic=wm_reply_topic(DASHBOARD_SRC), id=f"replay-world-{serial}", ts=t,
                    src=WORLD_SRC, inc=0, body=reply)
