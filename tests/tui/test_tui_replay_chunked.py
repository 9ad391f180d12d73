"""The replay dashboard's data source reads a finished recording a chunk at a time: it
never holds the whole file's messages, a seek reads the chunks it lands in, and the
frames are those of reading the file whole (written here, small chunks so that a short
mission has many)."""

from __future__ import annotations

from pathlib import Path

import pytest

from mrss.messages import DataRequest, RobotData, encode
from mrss.recording import mcap_writer
from mrss.recording.format import RecordedMessage
from mrss.recording.mcap_reader import McapRecording
from mrss.recording.mcap_writer import McapRecordingWriter
from mrss.tui.replay.app import ReplayApp
from mrss.tui.replay.chunked import CACHED_CHUNKS, ChunkedFrames
from mrss.tui.replay.index import TOPICS_WINDOW
from mrss.tui.replay.tape import Tape
from mrss.world.topics import WM_REQUEST_TOPIC
from tests.tui.tui_helpers import run

T0 = 1_700_000_000.0
MESSAGES = 3_000


@pytest.fixture
def recording(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """50 minutes of one robot's telemetry a second, a world model write every 100 s,
    and each tenth message recorded twice (a copy the tape leaves out), in 4 KiB chunks."""
    monkeypatch.setattr(mcap_writer, "CHUNK_BYTES", 4096)
    path = tmp_path / "long.mcap"
    with path.open("wb") as out:
        writer = McapRecordingWriter(out, created=T0)
        for i in range(MESSAGES):
            frames = encode(RobotData(robot="ugv1", data={"lat": 47.0 + i * 1e-5,
                                                          "lon": 15.0}), src="rcl")
            writer.write(RecordedMessage(T0 + i, frames))
            if i % 10 == 0:
                writer.write(RecordedMessage(T0 + i, frames))
            if i % 100 == 50:
                writer.write(RecordedMessage(T0 + i, encode(DataRequest(
                    request_id=f"w{i}", function="wm.upsert",
                    args=[{"id": f"hs{i}", "kind": "hotspot",
                           "position": {"lat": 47.0, "lon": 15.0}}]),
                    src="datalayer", topic=WM_REQUEST_TOPIC)))
        writer.finish()
    return path


def whole(path: Path) -> Tape:
    with path.open("rb") as handle:
        return Tape._read(McapRecording(handle).recorded())


def test_the_tape_reads_chunks_as_asked_and_gives_the_whole_files_frames(
        recording: Path) -> None:
    tape = Tape.load(recording)
    frames = tape.frames
    assert isinstance(frames, ChunkedFrames)
    assert frames.reads == 0  # opening reads the summary, no chunk
    expected = whole(recording)
    assert [(f.t, f.env) for f in frames] == [(f.t, f.env) for f in expected.frames]
    assert tape.left_out == expected.left_out == {
        "a copy of a message already recorded": MESSAGES // 10}
    chunks = frames.reads
    assert chunks == frames.chunks > 4 * CACHED_CHUNKS  # one pass read each chunk once
    assert frames.cached <= CACHED_CHUNKS
    middle = len(frames) // 2
    before = frames.reads
    assert frames[middle] == expected.frames[middle]
    assert frames[middle - 3:middle + 3] == expected.frames[middle - 3:middle + 3]
    assert frames.reads - before <= 2  # the chunk it is in (and its neighbour)


def test_the_replay_dashboard_seeks_by_reading_a_few_chunks(recording: Path) -> None:
    tape = Tape.load(recording)
    frames = tape.frames
    assert isinstance(frames, ChunkedFrames)
    app = ReplayApp(tape, name="long", play=False, keyframe_every=20)
    assert frames.cached <= CACHED_CHUNKS
    chunks = frames.chunks
    assert frames.reads <= chunks + 1  # the index pass read each once (the player: the first)
    # what a seek applies: the messages from the keyframe, the last TOPICS_WINDOW for
    # the Messages screen's topics; in chunks, and one more at each end
    per_chunk = len(frames) / chunks
    window = int((TOPICS_WINDOW + 20) / per_chunk) + 2
    assert window < chunks / 2, (window, chunks)

    async def body() -> None:
        async with app.run_test(size=(160, 50)):
            for t in (T0 + 2900, T0 + 30, T0 + 1651.5):
                before = frames.reads
                app.seek_to(t)
                assert frames.reads - before <= window, t
                assert frames.cached <= CACHED_CHUNKS
                assert app.player.time == t
                mark = app.map_model.robots["ugv1"]
                assert mark.lat == pytest.approx(47.0 + int(t - T0) * 1e-5)
            assert {f"hs{i}" for i in range(50, 1651, 100)} == set(app.map_model.objects)
    run(body())
