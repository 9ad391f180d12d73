"""Corrupt, truncated and foreign MCAP files: `mrss recording info/export` and `mrss
replay` say what is wrong and where (the byte offset), never with a traceback."""

from __future__ import annotations

import io
import json
from collections.abc import Callable
from pathlib import Path

import pytest
from mcap.writer import Writer

from mrss.cli import main
from mrss.messages import Percept, encode
from mrss.recording.format import RecordedMessage
from mrss.recording.mcap_writer import McapRecordingWriter
from tests.commands.cli_bus import mrss, running_bus


def good_recording(count: int = 40) -> tuple[bytes, list[int]]:
    """A finished recording of `count` percepts, a chunk each ten; where each chunk ends."""
    out = io.BytesIO()
    writer = McapRecordingWriter(out, created=1.0)
    ends = []
    for i in range(count):
        writer.write(RecordedMessage(1.0 + i, encode(Percept(literal=f"p({i})"), src="t")))
        if i % 10 == 9:
            writer._chunk_opened = 0.0  # noqa: SLF001 - as if a second had passed
            writer.flush()
            ends.append(out.tell())
    writer.finish()
    return out.getvalue(), ends


def truncated(data: bytes, ends: list[int]) -> tuple[bytes, int, str]:
    return data[:ends[1] + 40], ends[1], "truncated record"


def flipped(data: bytes, ends: list[int]) -> tuple[bytes, int, str]:
    spot = ends[1] + 120  # inside the third chunk's compressed data
    return data[:spot] + bytes([data[spot] ^ 0xFF]) + data[spot + 1:], ends[1], "corrupt"


def foreign(data: bytes, ends: list[int]) -> tuple[bytes, int, str]:
    out = io.BytesIO()
    writer = Writer(out)
    writer.start(profile="ros2", library="rosbag2")
    schema = writer.register_schema("std_msgs/String", "ros2msg", b"string data")
    channel = writer.register_channel("/chatter", "cdr", schema)
    writer.add_message(channel, log_time=1, publish_time=1, data=b"\x00\x01")
    writer.finish()
    return out.getvalue(), 8, "not an MRSS recording (profile 'ros2'"


def not_mcap(data: bytes, ends: list[int]) -> tuple[bytes, int, str]:
    return b"PK\x03\x04 a zip file" + data[20:], 0, "bad magic"


DAMAGES = [truncated, flipped, foreign, not_mcap]


@pytest.mark.parametrize("damage", DAMAGES)
@pytest.mark.parametrize("command", [["info"], ["export", "--format", "csv"],
                                     ["export", "--format", "jsonl"], ["report"],
                                     ["report", "--format", "json"]])
def test_recording_commands_name_the_damage_and_its_offset(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], command: list[str],
        damage: Callable[[bytes, list[int]], tuple[bytes, int, str]]) -> None:
    data, offset, reason = damage(*good_recording())
    path = tmp_path / "bad.mcap"
    path.write_bytes(data)
    assert main(["recording", command[0], str(path), *command[1:]]) == 2
    err = capsys.readouterr().err
    assert f"{path}: at byte offset {offset}: " in err and reason in err, err
    assert "Traceback" not in err and "internal error" not in err


def test_the_intact_part_of_a_damaged_file_is_still_shown(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    data, offset, _ = truncated(*good_recording())
    path = tmp_path / "cut.mcap"
    path.write_bytes(data)
    assert main(["recording", "export", str(path), "--format", "jsonl"]) == 2
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 20  # the two complete chunks


def test_the_report_of_a_damaged_file_counts_what_comes_before_it(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    data, offset, _ = truncated(*good_recording())
    path = tmp_path / "cut.mcap"
    path.write_bytes(data)
    assert main(["recording", "report", str(path), "--format", "json"]) == 2
    out, err = capsys.readouterr()
    report = json.loads(out)
    assert report["span_s"] == 19.0  # the percepts of the two complete chunks: 1 s apart
    assert "the recording has no project" in err
    assert f"at byte offset {offset}: truncated record" in err


@pytest.mark.parametrize("damage", DAMAGES)
def test_replay_names_the_damage_and_its_offset(
        tmp_path: Path, damage: Callable[[bytes, list[int]], tuple[bytes, int, str]]) -> None:
    data, offset, reason = damage(*good_recording())
    path = tmp_path / "bad.mcap"
    path.write_bytes(data)
    with running_bus() as live:
        out = mrss("replay", str(path), "--run-dir", str(live.run_dir),
                   "--as-fast-as-possible")
        assert out.returncode == 2
        assert f"at byte offset {offset}: " in out.stderr and reason in out.stderr, out.stderr
        assert "Traceback" not in out.stderr
        if damage in (truncated, flipped):
            assert [live.next().body for _ in range(20)] == [
                Percept(literal=f"p({i})") for i in range(20)]
