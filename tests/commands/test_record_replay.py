"""`mrss record` and `mrss replay` as processes on real buses (proxy threads, ipc sockets)."""

from __future__ import annotations

import io
import json
import os
import signal
import struct
import time
import zlib
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import msgpack
import pytest

from mrss.bus import Publisher, ReliableReceiver, ReliableSender
from mrss.bus.wire import message_frames
from mrss.cli import main
from mrss.messages import ActionRequest, Envelope, Message, Percept, RobotData, decode, encode
from mrss.recording.files import recorded_messages
from mrss.recording.format import RecordedMessage, RecordingError, RecordingWriter
from mrss.recording.mcap_reader import McapRecording
from mrss.testing import wait_until
from tests.commands.cli_bus import (
    ROOT,
    Bus,
    CliProcess,
    mrss,
    mrss_process,
    running_bus,
    short_dir,
)

Seen = tuple[str, str, str, Message]  # topic, message id, sender, body


@contextmanager
def recorder(bus: Bus, out: Path, *extra: str) -> Iterator[CliProcess]:
    """`mrss record` on `bus`, once it says it is recording."""
    with mrss_process("record", "--run-dir", str(bus.run_dir), "--out", str(out),
                      *extra) as rec:
        rec.wait_line("recording ")
        yield rec


def recorded(path: Path) -> list[RecordedMessage]:
    """The complete entries of a recording that may still be being written."""
    found: list[RecordedMessage] = []
    try:
        with path.open("rb") as handle:
            for entry in recorded_messages(handle):
                found.append(entry)
    except (OSError, RecordingError):
        pass  # not created yet, or a last entry half written
    return found


def seen(entries: list[RecordedMessage]) -> list[Seen]:
    """The bus messages in well-formed entries, batches unpacked, in order."""
    result = []
    for entry in entries:
        if not entry.malformed:
            for topic, payload in message_frames(list(entry.frames)):
                env = decode(topic, payload)
                result.append((env.topic, env.id, env.src, env.body))
    return result


def received(bus: Bus, count: int) -> list[Seen]:
    """The next `count` messages on `bus`, each of which must be marked as replayed."""
    envs: list[Envelope] = [bus.next() for _ in range(count)]
    assert all(env.replayed for env in envs)
    return [(env.topic, env.id, env.src, env.body) for env in envs]


def start_recording(pub: Publisher, out: Path) -> None:
    """Publish sync percepts until the recorder has one: its subscription is in place."""
    counter = iter(range(1, 10_000))
    wait_until(lambda: pub.publish(Percept(literal=f"sync({next(counter)})"))
               and recorded(out), 15, interval=0.05, message="the recorder records")


def body_sequence(items: list[Seen], src: str = "tester") -> list[Message]:
    """What `src` sent after the sync percepts, each message once (a reliable resend
    repeats an id). Messages of one sender keep their order; different senders' mix."""
    ids: set[str] = set()
    bodies = []
    for _, msg_id, sender, body in items:
        if sender == src and msg_id not in ids and not (
                isinstance(body, Percept) and body.literal.startswith("sync(")):
            ids.add(msg_id)
            bodies.append(body)
    return bodies


def test_record_then_replay_preserves_topics_bodies_and_order(tmp_path: Path) -> None:
    out = tmp_path / "session.mcap"
    telemetry = [RobotData(robot="uav1", data={"alt": float(i)}) for i in range(200)]
    action = ActionRequest(uuid="u1", name="go", args=[1, "b"], robot="uav1")
    with running_bus() as live, recorder(live, out) as rec:
        handled: list[Envelope] = []
        with Publisher(live.endpoints, src="tester") as pub, \
                ReliableSender(live.endpoints, src="reasoner", channel="action") as tx, \
                ReliableReceiver(live.endpoints, src="rcl", channel="action",
                                 handler=handled.append):
            start_recording(pub, out)
            for i in range(5):
                pub.publish(Percept(literal=f"fire(z{i})"))
            for msg in telemetry:  # a burst: the publisher batches it
                pub.publish(msg)
            pub.send_frames([b"percept", b"\xc1 not msgpack"])
            pub.send_frames([b"junk"])
            tx.send(action)
            tx.flush(15)
            pub.publish(Percept(literal="done"))
            wait_until(lambda: Percept(literal="done") in body_sequence(seen(recorded(out))),
                       15, interval=0.05, message="the last message is recorded")
        rec.proc.send_signal(signal.SIGINT)
        assert rec.finish() == 0, rec.stderr()
    entries = recorded(out)
    assert rec.lines[-1] == f"recorded {len(entries)} messages (2 malformed) to {out}"
    assert body_sequence(seen(entries)) == [
        *(Percept(literal=f"fire(z{i})") for i in range(5)), *telemetry,
        Percept(literal="done")]
    assert body_sequence(seen(entries), src="reasoner") == [action]
    # reliable data is recorded as the message it carries; acks are not recorded
    assert not [e for e in entries if e.frames[0].startswith(b"rel.")]
    assert [e.note for e in entries if e.malformed] == [
        "not msgpack: FormatError", "unexpected message of 1 frame(s)"]
    assert [e.t for e in entries] == sorted(e.t for e in entries)

    with running_bus() as other:
        replay = mrss("replay", str(out), "--run-dir", str(other.run_dir), "--speed", "20")
        assert replay.returncode == 0, replay.stderr
        expected = seen(entries)
        assert received(other, len(expected)) == expected
        assert other.sub.recv(timeout=0.2) is None
    assert f"replayed {len(entries) - 2} messages" in replay.stdout
    assert "(skipped 2 malformed, 0 undecodable)" in replay.stdout
    malformed_at = [e.offset for e in entries if e.malformed]
    for offset in malformed_at:
        assert f"skipped malformed message at offset {offset}" in replay.stderr
    assert ("action.request", action) in [(topic, body) for topic, _, _, body in expected]


def write_recording(path: Path, entries: list[RecordedMessage]) -> list[int]:
    """Write `entries` to `path`; the offset where each starts, and the file's end."""
    out = io.BytesIO()
    writer = RecordingWriter(out, created=0.0)
    starts = []
    for entry in entries:
        starts.append(out.tell())
        writer.write(entry)
    starts.append(out.tell())
    path.write_bytes(out.getvalue())
    return starts


def percept_entry(t: float, literal: str, note: str = "") -> RecordedMessage:
    return RecordedMessage(t, encode(Percept(literal=literal), src="rec"), note)


def test_replay_keeps_the_recorded_spacing_scaled_by_speed(tmp_path: Path) -> None:
    path = tmp_path / "spaced.mrssrec"
    write_recording(path, [percept_entry(100.0 + 2 * i, f"p({i})") for i in range(3)])
    with running_bus() as live, mrss_process("replay", str(path), "--run-dir",
                                             str(live.run_dir), "--speed", "8") as cli:
        arrivals = []
        for i in range(3):
            assert live.next(timeout=20).body == Percept(literal=f"p({i})")
            arrivals.append(time.monotonic())
        assert cli.finish() == 0, cli.stderr()
    span = arrivals[-1] - arrivals[0]
    assert span >= 0.4  # 4 s recorded at 8x: 0.5 s; never sent back to back
    assert span < 3.0   # nor at the recorded pace (4 s)


def test_as_fast_as_possible_ignores_the_timing(tmp_path: Path) -> None:
    path = tmp_path / "hour.mrssrec"
    write_recording(path, [percept_entry(1800.0 * i, f"p({i})") for i in range(3)])
    with running_bus() as live:
        out = mrss("replay", str(path), "--run-dir", str(live.run_dir),
                   "--as-fast-as-possible")
        assert out.returncode == 0, out.stderr
        assert [live.next().body for _ in range(3)] == [Percept(literal=f"p({i})")
                                                        for i in range(3)]


def damage_truncate(data: bytes, starts: list[int]) -> tuple[bytes, int, str]:
    return data[:starts[3] + 5], starts[3], "truncated entry"


def damage_flip(data: bytes, starts: list[int]) -> tuple[bytes, int, str]:
    spot = starts[1] + 12
    return data[:spot] + bytes([data[spot] ^ 0x40]) + data[spot + 1:], starts[1], \
        "corrupt entry: checksum mismatch"


@pytest.mark.parametrize("damage", [damage_truncate, damage_flip])
def test_damaged_file_replays_the_valid_part_then_exits_2_with_the_offset(
        tmp_path: Path, damage: Callable[[bytes, list[int]], tuple[bytes, int, str]]) -> None:
    path = tmp_path / "damaged.mrssrec"
    starts = write_recording(path, [percept_entry(float(i), f"p({i})") for i in range(4)])
    data, offset, reason = damage(path.read_bytes(), starts)
    path.write_bytes(data)
    intact = starts.index(offset)
    with running_bus() as live:
        out = mrss("replay", str(path), "--run-dir", str(live.run_dir),
                   "--as-fast-as-possible")
        assert out.returncode == 2
        assert [live.next().body for _ in range(intact)] == [Percept(literal=f"p({i})")
                                                             for i in range(intact)]
        assert live.sub.recv(timeout=0.2) is None
    assert f"at byte offset {offset}: {reason}" in out.stderr
    assert f"({intact} messages before it were replayed)" in out.stderr


def raw_block(value: object) -> bytes:
    body: bytes = msgpack.packb(value, use_bin_type=True)
    return struct.pack("!II", len(body), zlib.crc32(body)) + body


def test_prefix_filter_skips_malformed_and_undecodable_entries(tmp_path: Path) -> None:
    path = tmp_path / "mixed.mrssrec"
    data = RobotData(robot="ugv1", data={"battery": 0.5})
    starts = write_recording(path, [
        percept_entry(1.0, "a"),
        RecordedMessage(1.1, encode(data, src="rec")),
        RecordedMessage(1.2, (b"percept", b"\xc1"), "not msgpack: ExtraData"),
    ])
    with path.open("ab") as handle:
        handle.write(raw_block({"not": "an entry"}))
        handle.write(raw_block([1.3, [*encode(Percept(literal="b"), src="rec")], ""]))
    with running_bus() as live:
        out = mrss("replay", str(path), "--run-dir", str(live.run_dir), "--prefix", "percept",
                   "--as-fast-as-possible")
        assert out.returncode == 0, out.stderr
        assert [live.next().body for _ in range(2)] == [Percept(literal="a"),
                                                        Percept(literal="b")]
        assert live.sub.recv(timeout=0.2) is None
    assert "replayed 2 messages" in out.stdout
    assert "(skipped 1 malformed, 1 undecodable)" in out.stdout
    assert f"malformed message at offset {starts[2]}: not msgpack" in out.stderr
    assert f"undecodable entry at offset {starts[3]}: entry is not [time" in out.stderr


def test_include_malformed_sends_garbage_as_recorded(tmp_path: Path) -> None:
    path = tmp_path / "garbage.mrssrec"
    write_recording(path, [RecordedMessage(1.0, (b"percept", b"\xc1"), "not msgpack"),
                           percept_entry(1.1, "after")])
    with running_bus() as live:
        out = mrss("replay", str(path), "--run-dir", str(live.run_dir), "--include-malformed",
                   "--as-fast-as-possible")
        assert out.returncode == 0, out.stderr
        assert live.next().body == Percept(literal="after")
        assert live.sub.dropped == 1  # the garbage reached the subscriber, which dropped it
    assert "replayed 2 messages" in out.stdout


def test_replay_refuses_what_is_not_a_recording(tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    text = tmp_path / "notes.txt"
    text.write_text("hello\n")
    with short_dir() as run_dir:
        assert main(["replay", str(text), "--run-dir", str(run_dir)]) == 2
        assert "at byte offset 0: neither an MCAP file nor an MRSS recording" in \
            capsys.readouterr().err
        assert main(["replay", str(tmp_path / "missing"), "--run-dir", str(run_dir)]) == 2
        assert "cannot read" in capsys.readouterr().err


def test_replay_without_a_bus_exits_2(tmp_path: Path) -> None:
    path = tmp_path / "one.mrssrec"
    write_recording(path, [percept_entry(1.0, "a")])
    with short_dir() as run_dir:
        out = mrss("replay", str(path), "--run-dir", str(run_dir), "--timeout", "0.3")
    assert out.returncode == 2
    assert "no bus" in out.stderr


def test_record_prefix_keeps_only_those_topics(tmp_path: Path) -> None:
    out = tmp_path / "percepts.mcap"
    with running_bus() as live, recorder(live, out, "--prefix", "percept") as rec:
        with Publisher(live.endpoints, src="tester") as pub:
            start_recording(pub, out)
            pub.publish(RobotData(robot="uav1", data={}))
            pub.publish(Percept(literal="kept"))
            wait_until(lambda: Percept(literal="kept") in body_sequence(seen(recorded(out))),
                       15, message="the percept is recorded")
        rec.proc.send_signal(signal.SIGTERM)
        assert rec.finish() == 0, rec.stderr()
    topics = {item[0] for item in seen(recorded(out))}
    assert topics == {"percept"}
    with out.open("rb") as handle:
        recording = McapRecording(handle)
        list(recording.entries())
    assert json.loads(recording.metadata["mrss"]["prefixes"]) == ["percept"]
    assert json.loads(recording.metadata["mrss"]["endpoints"]) == live.endpoints.to_dict()


def test_record_stops_after_its_duration(tmp_path: Path) -> None:
    out = tmp_path / "quiet.mcap"
    with running_bus() as live, recorder(live, out, "--duration", "0.3") as rec:
        assert rec.finish() == 0, rec.stderr()
    assert rec.lines[-1] == f"recorded 0 messages (0 malformed) to {out}"
    assert recorded(out) == []


def test_record_without_a_bus_exits_2_and_writes_nothing(tmp_path: Path) -> None:
    out = tmp_path / "never.mcap"
    with short_dir() as run_dir:
        result = mrss("record", "--run-dir", str(run_dir), "--out", str(out),
                      "--timeout", "0.3")
    assert result.returncode == 2
    assert "no bus" in result.stderr
    assert not out.exists()


def test_send_and_record_on_a_supervised_system(tmp_path: Path) -> None:
    env = {**os.environ, "MRSS_PROJECTS": str(ROOT / "tests" / "projects")}
    out = tmp_path / "system.mcap"
    with short_dir() as run_dir, \
            mrss_process("supervise", "busdemo", "--run-dir", str(run_dir), env=env) as system, \
            mrss_process("record", "--run-dir", str(run_dir), "--out", str(out),
                         "--timeout", "30") as rec:
        rec.wait_line("recording ", timeout=30)  # waited for the system's proxy
        sent = mrss("send", "--run-dir", str(run_dir), "percept", "hello(world)")
        assert sent.returncode == 0, sent.stderr
        wait_until(lambda: Percept(literal="hello(world)") in body_sequence(
            seen(recorded(out)), src="mrss-send"), 15, message="the percept is recorded")
        rec.proc.send_signal(signal.SIGINT)
        assert rec.finish() == 0, rec.stderr()
        system.proc.send_signal(signal.SIGINT)
        assert system.finish() == 0, system.stderr()


def test_a_killed_recorder_leaves_a_replayable_file(tmp_path: Path) -> None:
    out = tmp_path / "killed.mcap"
    with running_bus() as live, recorder(live, out) as rec:
        with Publisher(live.endpoints, src="tester") as pub:
            start_recording(pub, out)
            pub.publish(Percept(literal="last(words)"))
            wait_until(lambda: Percept(literal="last(words)") in body_sequence(
                seen(recorded(out))), 15, message="the percept is recorded")
        rec.proc.kill()
        rec.finish()
        entries = recorded(out)  # every complete chunk
        replay = mrss("replay", str(out), "--run-dir", str(live.run_dir),
                      "--as-fast-as-possible")
        assert replay.returncode == 2, replay.stderr  # the file ends before its footer
        assert f"({len(entries)} messages before it were replayed)" in replay.stderr


def test_a_fast_replay_delivers_everything_before_it_exits(tmp_path: Path) -> None:
    path = tmp_path / "burst.mrssrec"
    count = 5000  # within the queues of one hop (10,000 ZeroMQ messages each side)
    write_recording(path, [RecordedMessage(i * 1e-4, encode(
        RobotData(robot="uav1", data={"i": i}), src="rec")) for i in range(count)])
    with running_bus(prefixes=("robot.",)) as live:
        out = mrss("replay", str(path), "--run-dir", str(live.run_dir),
                   "--as-fast-as-possible")
        assert out.returncode == 0, out.stderr
        got = [live.next().body for _ in range(count)]
    assert got == [RobotData(robot="uav1", data={"i": i}) for i in range(count)]
