"""Seeking by time through the summary's chunk index gives what reading the whole file in
order and sorting gives, reading only the chunks it needs."""

from __future__ import annotations

import io
import random
from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap.writer import Writer

from mrss.messages import Percept, RobotData, encode
from mrss.recording import mcap_writer
from mrss.recording.format import RecordingError
from mrss.recording.mcap_reader import McapRecording
from mrss.recording.mcap_seek import IndexedRecording
from mrss.recording.mcap_writer import McapRecordingWriter

START = 1_700_000_000.0


def recording(monkeypatch: pytest.MonkeyPatch, *, count: int = 3000,
              jitter: float = 0.0, finish: bool = True) -> bytes:
    """A recording of `count` messages in small chunks; log times step 1 ms, each moved
    by up to `jitter` s (a receive clock that steps back: chunks overlap in time)."""
    monkeypatch.setattr(mcap_writer, "CHUNK_BYTES", 4096)
    rng = random.Random(5)
    out = io.BytesIO()
    writer = McapRecordingWriter(out, created=START)
    for i in range(count):
        body = RobotData(robot=f"r{i % 3}", data={"type": "position", "lat": 1.0 + i,
                                                   "lon": 2.0}) if i % 2 else \
            Percept(literal=f"p({i})")
        t = START + i / 1000 + rng.uniform(-jitter, jitter)
        writer.received(t, list(encode(body, src="s")))
    if finish:
        writer.finish()
    return out.getvalue()


def in_order(data: bytes) -> list[tuple[int, bytes]]:
    entries = McapRecording(io.BytesIO(data)).entries()
    return sorted(((e.log_time, e.data) for e in entries), key=lambda x: x[0])


@pytest.mark.parametrize("jitter", [0.0, 0.05])
def test_a_seek_gives_the_messages_from_that_time_in_log_time_order(
        monkeypatch: pytest.MonkeyPatch, jitter: float) -> None:
    data = recording(monkeypatch, jitter=jitter)
    everything = in_order(data)
    indexed = IndexedRecording(io.BytesIO(data))
    assert indexed.chunks > 20 and indexed.messages == len(everything)
    rng = random.Random(1)
    targets = [everything[0][0] - 1, everything[-1][0], everything[-1][0] + 1,
               *(rng.randint(everything[0][0], everything[-1][0]) for _ in range(30))]
    for target in targets:
        expected = [(t, d) for t, d in everything if t >= target]
        found = [(e.log_time, e.data) for e in indexed.seek(target)]
        assert [t for t, _ in found] == [t for t, _ in expected]
        assert sorted(found) == sorted(expected)


class CountedReads(io.BytesIO):
    def __init__(self, data: bytes) -> None:
        super().__init__(data)
        self.read_bytes = 0

    def read(self, size: int | None = -1) -> bytes:
        chunk = super().read(size)
        self.read_bytes += len(chunk)
        return chunk


def test_a_seek_reads_one_chunk(monkeypatch: pytest.MonkeyPatch) -> None:
    data = recording(monkeypatch)
    source = CountedReads(data)
    indexed = IndexedRecording(source)
    opened = source.read_bytes
    middle = in_order(data)[1500][0]
    first = next(iter(indexed.seek(middle)))
    assert first.log_time == middle
    assert source.read_bytes - opened < 4096  # one compressed chunk of 4 KiB


def test_a_file_without_its_summary_is_a_clear_error(monkeypatch: pytest.MonkeyPatch,
                                                      tmp_path: Path) -> None:
    data = recording(monkeypatch, count=500, finish=False)
    with pytest.raises(RecordingError, match="did not finish") as found:
        IndexedRecording(io.BytesIO(data))
    assert found.value.offset == len(data)
    with pytest.raises(RecordingError, match="bad magic"):
        IndexedRecording(io.BytesIO(b"not mcap at all"))


def test_a_damaged_chunk_names_its_offset(monkeypatch: pytest.MonkeyPatch) -> None:
    data = bytearray(recording(monkeypatch, count=500))
    indexed = IndexedRecording(io.BytesIO(bytes(data)))
    chunk = indexed._chunks[3]
    data[chunk.offset + 60] ^= 0xFF  # inside its compressed records
    damaged = IndexedRecording(io.BytesIO(bytes(data)))
    with pytest.raises(RecordingError, match="corrupt chunk") as found:
        list(damaged.seek(chunk.start))
    assert found.value.offset == chunk.offset


def test_the_index_read_is_the_mcap_librarys_summary(monkeypatch: pytest.MonkeyPatch) -> None:
    data = recording(monkeypatch, count=800)
    summary = make_reader(io.BytesIO(data)).get_summary()
    assert summary is not None and summary.statistics is not None
    indexed = IndexedRecording(io.BytesIO(data))
    assert indexed._chunks == sorted(
        (c.message_start_time, c.message_end_time, c.chunk_start_offset, c.chunk_length)
        for c in summary.chunk_indexes)
    assert (indexed.start, indexed.end, indexed.messages) == (
        summary.statistics.message_start_time, summary.statistics.message_end_time,
        summary.statistics.message_count)
    topics = {e.topic: e.schema for e in indexed.seek(0)}
    assert topics["percept"] == "mrss.percept"
    assert topics["robot.r1.data"] == "mrss.robot.data"
    assert topics["robot.r1.location"] == "foxglove.LocationFix"


def test_another_profiles_mcap_file_is_refused_at_its_header() -> None:
    out = io.BytesIO()
    other = Writer(out)
    other.start(profile="ros2", library="elsewhere")
    other.finish()  # type: ignore[no-untyped-call]
    with pytest.raises(RecordingError, match="not an MRSS recording") as found:
        IndexedRecording(io.BytesIO(out.getvalue()))
    assert found.value.offset == 8
