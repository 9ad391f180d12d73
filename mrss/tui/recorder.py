"""The dashboard's bus recording (palette: "Start recording" / "Stop recording").

What `mrss record` does, on a thread of the dashboard: every message on the bus, frames
as received, into `<run dir>/recording-YYYYmmdd-HHMMSS.mcap` (the current folder when
the bus is not in a run dir, e.g. tcp endpoints); `mrss replay FILE` plays it back. The
recorder has its own subscriber socket (all topics, whatever the dashboard shows), so it
costs the dashboard's thread nothing. `stop()` ends it and says how many it wrote.
"""

from __future__ import annotations

import threading
import time
from pathlib import Path

from mrss.bus import BusEndpoints
from mrss.recording.mcap_writer import McapRecordingWriter
from mrss.recording.recorder import BusRecorder
from mrss.tui.mission import run_dir_of

CONNECT_TIMEOUT = 5.0


def recording_path(endpoints: BusEndpoints, now: float | None = None) -> Path:
    """Where a recording started now goes."""
    folder = run_dir_of(endpoints.backend) or Path.cwd()
    stamp = time.strftime("%Y%m%d-%H%M%S", time.localtime(now))
    return folder / f"recording-{stamp}.mcap"


class DashboardRecording:
    """One recording in progress: `start` it, `stop` it; `count`, `error` as it goes."""

    def __init__(self, endpoints: BusEndpoints, path: Path) -> None:
        self.endpoints = endpoints
        self.path = path
        self.error = ""
        self._writer: McapRecordingWriter | None = None
        self.started = threading.Event()  # connected and writing (or failed: `error`)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="tui-recording", daemon=True)

    def start(self) -> None:
        self._thread.start()

    @property
    def count(self) -> int:
        """Messages written so far."""
        return self._writer.count if self._writer is not None else 0

    @property
    def running(self) -> bool:
        return self._thread.is_alive()

    def _run(self) -> None:
        try:
            recorder = BusRecorder(self.endpoints, [""])
        except Exception as exc:  # a bad endpoint: said, never raised into the dashboard
            self.error = f"cannot connect: {exc}"
            self.started.set()
            return
        try:
            if not recorder.wait_connected(CONNECT_TIMEOUT, self._stop):
                self.error = "" if self._stop.is_set() else \
                    f"no bus proxy answered within {CONNECT_TIMEOUT:g} s"
                return
            try:
                handle = self.path.open("wb")
            except OSError as exc:
                self.error = f"cannot write {self.path}: {exc.strerror or exc}"
                return
            with handle:
                writer = McapRecordingWriter(handle, created=time.time(),
                                             endpoints=self.endpoints.to_dict(), prefixes=[""])
                self._writer = writer
                self.started.set()
                recorder.record(writer, self._stop, None)
                writer.finish()
        except Exception as exc:  # the dashboard stays up whatever the disk does
            self.error = f"recording stopped: {exc}"
        finally:
            recorder.close()
            self.started.set()

    def stop(self, timeout: float = 5.0) -> str:
        """End the recording; what happened, for the operator."""
        self._stop.set()
        self._thread.join(timeout)
        if self.error:
            return f"recording failed: {self.error}"
        return f"recorded {self.count} messages to {self.path} (mrss replay plays it)"
