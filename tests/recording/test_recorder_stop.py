"""A recorder that drains its queue at most every GATHER seconds still records what was
queued when it is stopped (a real proxy on a thread, a real publisher)."""

from __future__ import annotations

import io
import threading
import time
from pathlib import Path

from mrss.bus import BusEndpoints, ProxyThread, Publisher
from mrss.messages import Percept
from mrss.recording.mcap_reader import McapRecording
from mrss.recording.mcap_writer import McapRecordingWriter
from mrss.recording.recorder import GATHER, BusRecorder


def test_what_is_queued_when_the_recorder_is_stopped_is_recorded(tmp_path: Path) -> None:
    endpoints = BusEndpoints.ipc(tmp_path)
    with ProxyThread(endpoints), Publisher(endpoints, src="p") as pub:
        recorder = BusRecorder(endpoints, ["percept"])
        try:
            assert recorder.wait_connected(10, threading.Event())
            pub.publish(Percept(literal="queued(1)"))
            pub.flush()
            assert recorder._sock.poll(10_000)  # it is in the recorder's queue
            out = io.BytesIO()
            writer = McapRecordingWriter(out, created=time.time())
            stop = threading.Event()
            stop.set()  # stopped before it drained anything
            recorder.record(writer, stop, None, gather=GATHER)
            writer.finish()
        finally:
            recorder.close()
    out.seek(0)
    literals = [e.value()["body"]["literal"] for e in McapRecording(out).entries()]
    assert literals == ["queued(1)"]
