"""`mrss bench record` through real processes: a bus proxy, `mrss record`, and this
process publishing the mission mix at a set rate (or as fast as it can).

The recorder's CPU is read from the OS (psutil) from the first message sent until it has
caught up: an end marker sent after the load is in the file (read as it grows); what it
recorded is what the file's summary counts (less the markers), compared with what was
sent.
"""

from __future__ import annotations

import io
import os
import queue
import re
import signal
import subprocess
import tempfile
import threading
import time
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path

import psutil
from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.reader import make_reader
from mcap.records import Chunk
from mcap.records import Message as McapMessage
from mcap.stream_reader import breakup_chunk

from mrss.bench.record_traffic import mission_message
from mrss.bus import BusEndpoints, Publisher
from mrss.interpreter import python_module
from mrss.messages import Message, Percept
from mrss.recording.mcap_reader import MAGIC
from mrss.recording.mcap_writer import LOCATION_SUFFIX

_RECORDED = re.compile(r"recorded (\d+) messages")


class _Process:
    """A child whose stdout lines are read on a thread; stopped by `stop`."""

    def __init__(self, argv: list[str]) -> None:
        self.proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                     text=True, start_new_session=True)
        self.lines: queue.Queue[str | None] = queue.Queue()
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.lines.put(line.strip())
        self.lines.put(None)

    def wait_line(self, start: str, timeout: float) -> str:
        deadline = time.monotonic() + timeout
        while True:
            try:
                line = self.lines.get(timeout=max(0.0, deadline - time.monotonic()))
            except queue.Empty:
                line = None
            if line is None:
                raise RuntimeError(f"no line starting {start!r} within {timeout} s: "
                                   f"{self.stop()}")
            if line.startswith(start):
                return line

    def stop(self) -> str:
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        err = self.proc.stderr.read() if self.proc.stderr else ""
        for stream in (self.proc.stdout, self.proc.stderr):
            if stream is not None:
                stream.close()
        return err


@dataclass(frozen=True)
class LoadResult:
    sent: int
    send_s: float  # how long sending took
    busy_s: float  # from the first message sent until the recorder had caught up
    cpu_s: float  # the recorder's CPU time in that span
    recorded: int  # bus messages in the file (its summary; LocationFix not counted)
    reported: int  # what `mrss record` said it recorded
    size: int

    @property
    def dropped(self) -> int:
        return self.sent - self.recorded

    @property
    def cpu_percent(self) -> float:
        """The recorder's CPU as % of one core, over the span it was busy."""
        return 100 * self.cpu_s / self.busy_s if self.busy_s > 0 else float("nan")

    @property
    def rate(self) -> float:
        """Messages recorded per second of wall time while it was busy."""
        return self.recorded / self.busy_s if self.busy_s > 0 else float("nan")


def _cpu(proc: psutil.Process) -> float:
    times = proc.cpu_times()
    return float(times.user + times.system)


class _Tail:
    """The messages of an MCAP file being written, in the chunks it has completed since
    the last call (the recorder closes a chunk at most a second after its first message)."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.offset = len(MAGIC)

    def new_messages(self) -> list[bytes]:
        with self.path.open("rb") as handle:
            handle.seek(self.offset)
            data = handle.read()
        found: list[bytes] = []
        pos = 0
        while pos + 9 <= len(data):
            length = int.from_bytes(data[pos + 1:pos + 9], "little")
            end = pos + 9 + length
            if end > len(data):
                break  # a record still being written
            if data[pos] == Opcode.CHUNK:
                chunk = Chunk.read(ReadDataStream(io.BytesIO(data[pos + 9:end])))
                found.extend(bytes(r.data) for r in breakup_chunk(chunk)
                             if isinstance(r, McapMessage))
            pos = end
        self.offset += pos
        return found


class _EndMarker:
    """End markers sent after the load, one a second until the file has one: then the
    recorder has taken everything sent before it. A starved recorder's queue may
    overflow and drop a marker too; `in_file` counts those it recorded."""

    def __init__(self, pub: Publisher, tail: _Tail) -> None:
        self.pub, self.tail = pub, tail
        self.prefix = f"bench_end_{os.getpid()}_{time.monotonic_ns()}"
        self.sent = 0
        self.in_file = 0

    def _seen(self) -> bool:
        found = sum(self.prefix.encode() in data for data in self.tail.new_messages())
        self.in_file += found
        return found > 0

    def wait(self, proc: psutil.Process, timeout: float) -> tuple[float, float]:
        """(When a marker was seen in the file, by perf_counter; the recorder's CPU then.)"""
        deadline = time.monotonic() + timeout
        next_send = 0.0
        while time.monotonic() < deadline:
            if time.monotonic() >= next_send:
                self.pub.publish(Percept(literal=f"{self.prefix}({self.sent})"))
                self.pub.flush()
                self.sent += 1
                next_send = time.monotonic() + 1.0
            if self._seen():
                return time.perf_counter(), _cpu(proc)
            time.sleep(0.2)  # polling the file's growth
        raise RuntimeError(f"the recorder had not written an end marker after {timeout} s")

    def count_rest(self) -> None:
        """Count the markers in what the recorder wrote last (call once it has exited)."""
        self._seen()


def record_at(rate: float | None, count: int, messages: list[Message]) -> LoadResult:
    """Send `count` messages of the mix at `rate` msgs/s (None: as fast as possible) to
    a recorder, and measure it."""
    with ExitStack() as stack:
        tmp = Path(stack.enter_context(tempfile.TemporaryDirectory(prefix="mrss-bench-rec-")))
        run_dir = tmp / "run"
        run_dir.mkdir()
        proxy = _Process(python_module("mrss.bus.proxy", "--run-dir", str(run_dir)))
        stack.callback(proxy.stop)
        proxy.wait_line("ready", 60)
        out = tmp / "load.mcap"
        recorder = _Process(python_module("mrss", "record", "--run-dir", str(run_dir),
                                          "--out", str(out)))
        stack.callback(recorder.stop)
        recorder.wait_line("recording ", 60)  # after the proxy's welcome: subscribed
        rec = psutil.Process(recorder.proc.pid)
        pub = stack.enter_context(Publisher(BusEndpoints.ipc(run_dir), src="bench"))
        if not pub.wait_connected(30):
            raise RuntimeError("the bench's publisher did not join the proxy")
        cpu_start, start = _cpu(rec), time.perf_counter()
        sent = 0
        while sent < count:
            due = count if rate is None else min(count, int((time.perf_counter() - start)
                                                             * rate) + 1)
            while sent < due:
                pub.publish(messages[sent % len(messages)])
                sent += 1
            if rate is not None and sent < count:
                time.sleep(0.001)  # pacing the sender, not a synchronisation
        send_s = time.perf_counter() - start
        marker = _EndMarker(pub, _Tail(out))
        busy_end, cpu_end = marker.wait(rec, 300 + count / 500)
        recorder.proc.send_signal(signal.SIGINT)
        line = recorder.wait_line("recorded ", 120)
        match = _RECORDED.match(line)
        reported = int(match.group(1)) if match else -1
        recorder.proc.wait(timeout=60)
        marker.count_rest()
        with out.open("rb") as handle:
            summary = make_reader(handle).get_summary()
        assert summary is not None and summary.statistics is not None
        recorded = sum(n for cid, n in summary.statistics.channel_message_counts.items()
                       if not summary.channels[cid].topic.endswith(LOCATION_SUFFIX))
        recorded -= marker.in_file
        reported -= marker.in_file
        return LoadResult(sent, send_s, max(busy_end - start, send_s), cpu_end - cpu_start,
                          recorded, reported, os.path.getsize(out))


def mission_messages(count: int) -> list[Message]:
    """`count` distinct messages of the mix (a run cycles through them)."""
    import random
    rng = random.Random(2)
    return [mission_message(i, rng) for i in range(count)]
