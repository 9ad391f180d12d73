"""What `mrss bench soak` samples: every process under the root supervisor, and the files
of the run folder.

Every `every` seconds (wall clock) the sampler finds the root `mrss supervise` of the run
(a child of this process whose command line names the run folder) and reads, with
psutil, each of its descendants: the components by their process name (`mrss:<id>`),
the fork server, the embedded broker's Mosquitto (`broker/mosquitto`, where the broker runs
one) and the root itself; their RSS (MB), open file descriptors and
threads. It also sizes the files the components keep in the run folder, by what they
are (`FileKind`): a SQLite file counts with its -wal and -shm files, a log with its
rotated files (`mrss.log.1`, ...: `mrss.logfile`) and its lock file.
"""

from __future__ import annotations

import enum
import re
import threading
import time
from collections import defaultdict
from pathlib import Path

import psutil

from mrss.bench.soak_growth import Series
from mrss.runtime.forkserver import COMPONENT_COMM_PREFIX, is_fork_server

MB = 2**20
ROOT = "supervisor"
FORKSERVER = "forkserver"
MOSQUITTO = "mosquitto"  # the executable the embedded broker runs where installed
EMBEDDED_MOSQUITTO = "broker/mosquitto"


class Resource(enum.StrEnum):
    """What is sampled of a process."""

    RSS = "rss"
    FDS = "fds"
    THREADS = "threads"


class FileKind(enum.StrEnum):
    """The files of a run folder the soak watches, by what they hold."""

    JOURNAL = "journal"  # the RCL's action journal (<rcl>-journal.sqlite3)
    LEDGER = "ledger"  # the reasoner's percept ledger (<reasoner>-percepts.sqlite3)
    WORLDMODEL = "worldmodel"  # the world model's SQLite store
    LOG = "log"  # the run's log (mrss.log) and the supervisor's output

    @staticmethod
    def of(name: str) -> FileKind | None:
        if name.endswith("-journal.sqlite3"):
            return FileKind.JOURNAL
        if name.endswith("-percepts.sqlite3"):
            return FileKind.LEDGER
        if name.endswith((".sqlite", ".sqlite3", ".db")):
            return FileKind.WORLDMODEL
        if name.endswith(".log") or ".log." in name:
            return FileKind.LOG
        return None


SIDE_FILES = ("-wal", "-shm")
ROTATED = re.compile(r"^(.+\.log)\.(\d+|lock)$")  # mrss.log.3, mrss.log.lock: mrss.log


class Sampler:
    """Samples the system of `run_dir` on a thread until `stop()`; the series it kept,
    per process name and resource, and per file name (sizes in MB)."""

    def __init__(self, run_dir: Path, every: float, ignore: tuple[str, ...] = ()) -> None:
        self.run_dir = run_dir
        self.every = every
        self.ignore = ignore  # file names in the run folder that are not the system's
        self.processes: dict[str, dict[Resource, Series]] = defaultdict(
            lambda: {r: Series() for r in Resource})
        self.files: dict[str, Series] = defaultdict(Series)
        self.samples = 0
        self.t0: float | None = None
        self.elapsed = 0.0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="soak-sampler", daemon=True)

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(timeout=30)

    def _run(self) -> None:
        while not self._stop.is_set():
            self.sample()
            self._stop.wait(self.every)

    def sample(self) -> bool:
        """One sample now; False when the root supervisor was not found."""
        root = self._root()
        if root is None:
            return False
        now = time.monotonic()
        if self.t0 is None:
            self.t0 = now
        t = now - self.t0
        for name, proc in tree_processes(root).items():
            try:
                with proc.oneshot():
                    rss, fds, threads = proc.memory_info().rss, proc.num_fds(), \
                        proc.num_threads()
            except psutil.Error:
                continue  # it ended between the listing and the reading: a fault's work
            series = self.processes[name]
            series[Resource.RSS].add(t, rss / MB, proc.pid)
            series[Resource.FDS].add(t, float(fds), proc.pid)
            series[Resource.THREADS].add(t, float(threads), proc.pid)
        for name, size in self._file_sizes().items():
            self.files[name].add(t, size / MB)
        self.samples += 1
        self.elapsed = t
        return True

    def _root(self) -> psutil.Process | None:
        marker = str(self.run_dir)
        for child in psutil.Process().children():
            try:
                cmdline = child.cmdline()
            except psutil.Error:
                continue
            if "supervise" in cmdline and marker in cmdline:
                return child
        return None

    def _file_sizes(self) -> dict[str, int]:
        sizes: dict[str, int] = {}
        try:
            entries = list(self.run_dir.iterdir())
        except OSError:
            return sizes
        for path in entries:
            name = path.name
            for side in SIDE_FILES:
                name = name.removesuffix(side)
            if rotated := ROTATED.match(name):
                name = rotated[1]
            if name in self.ignore or FileKind.of(name) is None:
                continue
            try:
                sizes[name] = sizes.get(name, 0) + path.stat().st_size
            except OSError:
                continue  # removed meanwhile (a checkpointed -wal)
        return sizes


def tree_processes(root: psutil.Process) -> dict[str, psutil.Process]:
    """The root, its fork server and the components under it, by name."""
    found = {ROOT: root}
    try:
        children = root.children(recursive=True)
    except psutil.Error:
        return found
    for child in children:
        try:
            name, cmdline = child.name(), child.cmdline()
        except psutil.Error:
            continue
        if name.startswith(COMPONENT_COMM_PREFIX):
            found[name[len(COMPONENT_COMM_PREFIX):]] = child
        elif is_fork_server(cmdline, name):
            found[FORKSERVER] = child
        elif name == MOSQUITTO:  # the embedded broker's engine, a child of `mrss:broker`
            found[EMBEDDED_MOSQUITTO] = child
    return found
