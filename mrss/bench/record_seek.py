"""`mrss bench record`: seeking in a large recording (1 GB at full size).

The file has the recorder's layout and payloads: a minute of the mission mix is recorded
by `McapRecordingWriter`, read back, and its messages written again and again at later
times (zstd chunks of `CHUNK_BYTES`, the same channels and schemas, the summary index),
which is how a long mission's file looks without recording it for hours. A seek is the
first message at or after a random time on an open file (a replay keeps it open),
through `IndexedRecording` (mrss/recording/mcap_seek.py: one chunk read), and with the
`mcap` library's indexed reader as the reference; opening, which reads the summary (one
index entry a chunk), is measured apart. The file was just written: it is in the page cache.
"""

from __future__ import annotations

import io
import json
import os
import random
import time
from dataclasses import dataclass
from pathlib import Path

from mcap.reader import make_reader
from mcap.writer import CompressionType

from mrss.recording.mcap_fast import FastWriter
from mrss.recording.mcap_reader import McapRecording
from mrss.recording.mcap_seek import IndexedRecording
from mrss.recording.mcap_writer import CHUNK_BYTES, PROFILE, McapRecordingWriter
from mrss.recording.schemas import ENCODING, LOCATION_FIX, LOCATION_FIX_SCHEMA, all_kind_schemas

RATE = 1_000  # bus messages a second in the generated mission


@dataclass(frozen=True)
class Seeks:
    size: int
    messages: int
    chunks: int
    open_ms: list[float]  # open the file and read its summary (the index)
    seek_ms: list[float]  # the first message at or after a time, on an open reader
    seek_cpu_ms: list[float]
    library_ms: list[float]  # the same seeks with the mcap library's indexed reader


def _template(frames: list[list[bytes]]) -> list[tuple[str, str, bytes]]:
    """The recorder's own output for `frames`: (topic, schema, data) per MCAP message."""
    out = io.BytesIO()
    writer = McapRecordingWriter(out, created=time.time())
    for i, message in enumerate(frames):
        writer.received(i / RATE, message)
    writer.finish()
    out.seek(0)
    return [(e.topic, e.schema, e.data) for e in McapRecording(out).entries()]


def write_large(path: Path, size: int, frames: list[list[bytes]], chunk: int = CHUNK_BYTES) -> int:
    """Write a recording of at least `size` bytes; the number of messages in it."""
    template = _template(frames)
    schemas = {**all_kind_schemas(), LOCATION_FIX: LOCATION_FIX_SCHEMA}
    with path.open("wb") as handle:
        mcap = FastWriter(handle, chunk_size=chunk, compression=CompressionType.ZSTD)
        mcap.start(profile=PROFILE, library="mrss bench record")
        schema_ids: dict[str, int] = {}
        channels: dict[str, int] = {}
        for topic, schema, _ in template:
            if topic not in channels:
                if schema not in schema_ids:
                    schema_ids[schema] = mcap.register_schema(
                        schema, ENCODING, json.dumps(schemas[schema]).encode())
                channels[topic] = mcap.register_channel(topic, "json", schema_ids[schema])
        ids = [channels[topic] for topic, _, _ in template]
        datas = [data for _, _, data in template]
        step = 1_000_000_000 // RATE
        count = 0
        while handle.tell() < size:
            for channel, data in zip(ids, datas, strict=True):
                t = 1_700_000_000_000_000_000 + count * step // 2  # about 2 MCAP per bus msg
                mcap.add_message(channel, log_time=t, publish_time=t, data=data,
                                 sequence=count)
                count += 1
        mcap.finish()
    return count


def seek_latencies(path: Path, seeks: int, opens: int = 5, seed: int = 3) -> Seeks:
    """Open the file `opens` times, and seek to `seeks` random times on an open
    `IndexedRecording` (ms each; the seeks in CPU ms too), and as many with the `mcap`
    library's indexed reader (the reference)."""
    opened = []
    for _ in range(opens):
        start = time.perf_counter()
        with path.open("rb") as handle:
            indexed = IndexedRecording(handle)
        opened.append((time.perf_counter() - start) * 1000)
    rng = random.Random(seed)
    targets = [rng.randint(indexed.start, indexed.end) for _ in range(seeks)]
    wall, cpu, library = [], [], []
    with path.open("rb") as handle:
        indexed = IndexedRecording(handle)
        for target in targets:
            start, start_cpu = time.perf_counter(), time.process_time()
            entry = next(iter(indexed.seek(target)))
            wall.append((time.perf_counter() - start) * 1000)
            cpu.append((time.process_time() - start_cpu) * 1000)
            if entry.log_time < target:
                raise RuntimeError(f"seek to {target} gave a message at {entry.log_time}")
    with path.open("rb") as handle:
        reader = make_reader(handle)
        reader.get_summary()
        for target in targets:
            start = time.perf_counter()
            _, _, message = next(iter(reader.iter_messages(start_time=target)))
            library.append((time.perf_counter() - start) * 1000)
            if message.log_time < target:
                raise RuntimeError(f"seek to {target} gave a message at {message.log_time}")
    return Seeks(os.path.getsize(path), indexed.messages, indexed.chunks, opened, wall, cpu,
                 library)
