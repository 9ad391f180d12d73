"""The recorder's fast paths give what the slow ones give: FastWriter's file is the mcap
library Writer's, byte for byte; json_bytes is to_json's JSON; decode_raw is decode."""

from __future__ import annotations

import io
import json
import math
import random

import pytest
from mcap.writer import CompressionType, Writer

from mrss.messages import Percept, RobotData, decode, decode_raw, encode
from mrss.recording.mcap_fast import FastWriter
from mrss.recording.schemas import json_bytes, to_json


def _write(cls: type[Writer], chunk_size: int) -> bytes:
    rng = random.Random(7)
    out = io.BytesIO()
    mcap = cls(out, chunk_size=chunk_size, compression=CompressionType.ZSTD)
    mcap.start(profile="mrss", library="test")
    schema = mcap.register_schema("s", "jsonschema", b"{}")
    channels = [mcap.register_channel(f"t{i}", "json", schema) for i in range(5)]
    for i in range(3000):
        t = 1_000_000 + i * 1000 + rng.randint(-5000, 5000)  # not always in order
        mcap.add_message(rng.choice(channels), log_time=t, publish_time=t - 7,
                         data=json.dumps({"i": i, "x": rng.random()}).encode(), sequence=i)
        if i == 1500:
            mcap.flush()  # type: ignore[no-untyped-call]
        if i % 700 == 350:  # a channel registered while a chunk is open
            channels.append(mcap.register_channel(f"late{i}", "json", schema))
    mcap.finish()  # type: ignore[no-untyped-call]
    return out.getvalue()


@pytest.mark.parametrize("chunk_size", [4096, 256 * 1024])
def test_fast_writer_writes_the_librarys_file_byte_for_byte(chunk_size: int) -> None:
    fast = FastWriter(io.BytesIO())
    assert fast.fast, "the mcap library's internals changed: the fast path is off"
    assert _write(FastWriter, chunk_size) == _write(Writer, chunk_size)


@pytest.mark.parametrize("value", [
    {"a": [1, 2.5, "é", None, True], "b": {"c": b"\x00\xff"}},
    {"x": math.nan, "y": [math.inf, -math.inf], "z": b"raw"},
    [], "text", 3,
])
def test_json_bytes_is_to_jsons_json(value: object) -> None:
    assert json_bytes(value) == json.dumps(to_json(value), separators=(",", ":")).encode()


def test_decode_raw_gives_the_envelope_decode_gives_and_its_map() -> None:
    for body in (Percept(literal="p(1)"), RobotData(robot="r", data={"lat": 1.0, "b": b"x"})):
        topic, payload = encode(body, src="s", inc=3, cred=b"proof")
        env, envelope = decode_raw(topic, payload)
        assert envelope == decode(topic, payload)
        assert env["src"] == "s" and env["inc"] == 3 and env["cred"] == b"proof"
        assert env["body"] == (dict(body.__dict__))
