"""The recording file format: exact round trips, and damage reported at its offset."""

from __future__ import annotations

import io
import struct
import zlib

import msgpack
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mrss.recording.format import (
    MAGIC,
    MAX_BLOCK,
    RecordedMessage,
    RecordingError,
    RecordingReader,
    RecordingWriter,
)

messages = st.builds(
    RecordedMessage,
    t=st.floats(min_value=0.0, allow_nan=False, allow_infinity=False),  # Unix seconds
    frames=st.lists(st.binary(max_size=40), min_size=1, max_size=4).map(tuple),
    note=st.one_of(st.just(""), st.text(max_size=20)),
)


def write(entries: list[RecordedMessage]) -> tuple[bytes, list[int]]:
    """The file bytes and the offset of every block: the header's, then each entry's."""
    out = io.BytesIO()
    writer = RecordingWriter(out, created=1.5, endpoints={"frontend": "ipc:///f"},
                             prefixes=["percept"])
    starts = [len(MAGIC)]
    for entry in entries:
        starts.append(out.tell())
        writer.write(entry)
    starts.append(out.tell())  # the end
    return out.getvalue(), starts


def read_all(data: bytes, skips: list[tuple[int, str]] | None = None
             ) -> tuple[list[RecordedMessage], RecordingError | None]:
    """Every entry read before an error, and the error (None if the file was whole)."""
    found: list[RecordedMessage] = []
    skipped = skips if skips is not None else []
    try:
        reader = RecordingReader(io.BytesIO(data),
                                 on_skip=lambda offset, reason: skipped.append((offset, reason)))
        for entry in reader:
            found.append(entry)
    except RecordingError as exc:
        return found, exc
    return found, None


@given(st.lists(messages, max_size=8))
def test_round_trip_is_exact(entries: list[RecordedMessage]) -> None:
    data, starts = write(entries)
    reader = RecordingReader(io.BytesIO(data))
    assert reader.header == {"created": 1.5, "endpoints": {"frontend": "ipc:///f"},
                             "prefixes": ["percept"]}
    found = list(reader)
    assert found == entries
    assert [e.offset for e in found] == starts[1:-1]
    assert [e.malformed for e in found] == [bool(e.note) for e in entries]
    assert reader.offset == len(data)


@settings(max_examples=40)
@given(st.lists(messages, min_size=1, max_size=4))
def test_truncation_at_every_offset_is_reported_at_the_cut_entry(
        entries: list[RecordedMessage]) -> None:
    data, starts = write(entries)
    header_end = starts[1]
    for cut in range(len(data)):
        found, error = read_all(data[:cut])
        if cut < len(MAGIC):
            assert error is not None and error.offset == 0 and found == []
        elif cut < header_end:
            assert error is not None and error.offset == len(MAGIC) and found == []
        elif cut in starts:  # a clean end between entries: a shorter recording
            assert error is None
            assert found == entries[:starts.index(cut) - 1]
        else:
            assert error is not None
            broken = max(s for s in starts if s < cut)
            assert error.offset == broken
            assert "truncated" in error.reason
            assert found == entries[:starts.index(broken) - 1]


@settings(max_examples=60)
@given(st.lists(messages, min_size=1, max_size=4), st.data())
def test_a_damaged_byte_stops_reading_at_its_entry(entries: list[RecordedMessage],
                                                   data: st.DataObject) -> None:
    raw, starts = write(entries)
    position = data.draw(st.integers(0, len(raw) - 1), label="position")
    flip = data.draw(st.integers(1, 255), label="xor")
    damaged = raw[:position] + bytes([raw[position] ^ flip]) + raw[position + 1:]
    found, error = read_all(damaged)
    assert error is not None
    broken = max(s for s in [0, *starts] if s <= position)
    assert error.offset == broken
    intact = entries[:max(0, starts.index(broken) - 1)] if broken in starts else []
    assert found == intact


def test_not_a_recording_and_other_versions() -> None:
    for data, reason in [(b"", "bad magic"), (b"PK\x03\x04 zip file", "bad magic"),
                         (MAGIC[:7] + b"\x02" + b"\0" * 20, "version 2 is not supported"),
                         (MAGIC, "header is missing")]:
        found, error = read_all(data)
        assert error is not None and reason in error.reason and found == []


def block(value: object) -> bytes:
    body: bytes = msgpack.packb(value, use_bin_type=True)
    return struct.pack("!II", len(body), zlib.crc32(body)) + body


def test_undecodable_entries_are_skipped_with_their_offset() -> None:
    good = RecordedMessage(2.0, (b"percept", b"x"))
    data, starts = write([good])
    bad_offsets = [len(data), len(data) + len(block("hello"))]
    data += block("hello") + block([1.0, [], ""]) + block([2.5, [b"percept", b"y"], ""])
    skips: list[tuple[int, str]] = []
    found, error = read_all(data, skips)
    assert error is None
    assert found == [good, RecordedMessage(2.5, (b"percept", b"y"))]
    assert skips == [(bad_offsets[0], "entry is not [time, frames, note]"),
                     (bad_offsets[1], "entry frames are not a non-empty list of bytes")]


def test_an_absurd_length_is_corruption_not_an_allocation() -> None:
    data, starts = write([RecordedMessage(1.0, (b"a",))])
    data += struct.pack("!II", MAX_BLOCK + 1, 0)
    found, error = read_all(data)
    assert len(found) == 1
    assert error is not None and error.offset == starts[-1] and "exceeds" in error.reason


def test_writer_refuses_what_it_could_not_read_back() -> None:
    writer = RecordingWriter(io.BytesIO(), created=0.0)
    with pytest.raises(ValueError):
        writer.write(RecordedMessage(1.0, ()))
    with pytest.raises(ValueError):
        writer.write(RecordedMessage(float("nan"), (b"a",)))
    assert writer.count == 0
