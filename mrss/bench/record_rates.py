"""`mrss bench record`, in one process: the MCAP writer's rate per CPU second, where its
time goes, and the `mcap` library's own writer with the same messages as the reference.

Rates are messages per second of this process's CPU time (`time.process_time`), so other
work on a shared machine slows the wall clock but not the figure.
"""

from __future__ import annotations

import io
import time
from collections.abc import Callable
from dataclasses import dataclass

from mcap.writer import CompressionType, Writer

from mrss.messages import RobotData, decode_raw
from mrss.recording.mcap_fast import FastWriter
from mrss.recording.mcap_writer import CHUNK_BYTES, McapRecordingWriter
from mrss.recording.schemas import json_bytes, location_fix
from mrss.recording.transcode import transcode


@dataclass(frozen=True)
class Rate:
    messages: int
    cpu_s: float
    size: int  # bytes written

    @property
    def per_cpu_s(self) -> float:
        return self.messages / self.cpu_s if self.cpu_s > 0 else float("inf")


def _cpu(work: Callable[[], int]) -> tuple[float, int]:
    start = time.process_time()
    size = work()
    return time.process_time() - start, size


def writer_rate(frames: list[list[bytes]]) -> Rate:
    """What the recorder's writer does per bus message: check, JSON, LocationFix, MCAP."""
    def work() -> int:
        out = io.BytesIO()
        writer = McapRecordingWriter(out, created=time.time())
        now = time.time()
        for message in frames:
            writer.received(now, message)
        writer.finish()
        return len(out.getvalue())
    cpu, size = _cpu(work)
    return Rate(len(frames), cpu, size)


def encoded(frames: list[list[bytes]]) -> list[tuple[str, bytes]]:
    """Each message's topic and the JSON the recorder writes for it, its LocationFix too."""
    out: list[tuple[str, bytes]] = []
    for topic, payload in frames:
        env, envelope = decode_raw(topic, payload)
        out.append((envelope.topic, json_bytes(env)))
        body = envelope.body
        if isinstance(body, RobotData):
            fix = location_fix(body.robot, envelope.ts, body.data)
            if fix is not None:
                out.append((f"robot.{body.robot}.location", json_bytes(fix)))
    return out


def raw_writer_rate(frames: list[list[bytes]], writer: type[Writer] = Writer) -> Rate:
    """The reference: the `mcap` library's writer (zstd, the same chunk size) adding the
    same messages' JSON, already encoded: MCAP's own cost, nothing of MRSS."""
    messages = encoded(frames)

    def work() -> int:
        out = io.BytesIO()
        mcap = writer(out, chunk_size=CHUNK_BYTES, compression=CompressionType.ZSTD)
        mcap.start(profile="mrss", library="bench")
        schema = mcap.register_schema("any", "jsonschema", b"{}")
        channels: dict[str, int] = {}
        for i, (topic, data) in enumerate(messages):
            channel = channels.get(topic)
            if channel is None:
                channel = channels[topic] = mcap.register_channel(topic, "json", schema)
            mcap.add_message(channel, log_time=i, publish_time=i, data=data, sequence=i)
        mcap.finish()  # type: ignore[no-untyped-call]
        return len(out.getvalue())
    cpu, size = _cpu(work)
    return Rate(len(messages), cpu, size)


def stage_costs(frames: list[list[bytes]]) -> dict[str, float]:
    """Microseconds of CPU per bus message in each stage of the writer, measured alone:
    the fast path (msgspec, what the recorder does), the exact path it replaced on the
    common messages (the codec's unpack and checks, then the JSON module), adding to
    the MCAP chunk."""
    count = len(frames)
    decoded: list[tuple[dict[str, object], object]] = []

    def fast() -> int:
        for topic, payload in frames:
            transcode(topic, payload)
        return 0

    def check() -> int:
        decoded.extend(decode_raw(topic, payload) for topic, payload in frames)
        return 0

    def to_json() -> int:
        for env, _ in decoded:
            json_bytes(env)
        return 0

    costs = {"decode + check + JSON (msgspec)": _cpu(fast)[0],
             "was: unpack + validate (codec)": _cpu(check)[0],
             "was: JSON (json module)": _cpu(to_json)[0]}
    costs["MCAP add (one pass)"] = raw_writer_rate(frames, FastWriter).cpu_s
    return {stage: cpu / count * 1e6 for stage, cpu in costs.items()}
