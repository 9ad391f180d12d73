"""The run's log file is rotated by size (`[logs] max_mb`, `keep`; mrss.logfile), by
every process that writes it, and its readers still see the whole run.

Through real processes: `mrss supervise` of tests/supervision/projects/logsdemo with a
tiny `max_mb` (its `flooder` writes 10,000 lines while `chatty` and the root write too),
several writer processes sharing one file, and the dashboard mode's pipe (`LogPump`).
"""

from __future__ import annotations

import os
import re
import shutil
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import psutil
import pytest

from mrss import logfile
from mrss.chaos.history import HistoryWriter, load
from mrss.chaos.recorder import Recorder
from mrss.testing import wait_until

PROJECTS = Path(__file__).resolve().parent / "projects"
FLOOD = 10_000
MAX_MB = 0.05  # 52,428 bytes: the flood (about 0.8 MB) rotates the log some 15 times
# How far a file may grow: to twice max_bytes while one process rotates it (however long
# that takes), and the lines the writers had in flight then.
IN_FLIGHT = 3 * 300


def _project(tmp_path: Path, keep: int) -> Path:
    projects = tmp_path / "projects"
    shutil.copytree(PROJECTS / "logsdemo", projects / "logsdemo")
    toml = projects / "logsdemo" / "project.toml"
    toml.write_text(toml.read_text() + f"\n[logs]\nmax_mb = {MAX_MB}\nkeep = {keep}\n")
    return projects


def _supervise_a_flood(tmp_path: Path, keep: int) -> Path:
    run_dir = tmp_path / "run"
    run_dir.mkdir()
    proc = subprocess.Popen(
        [sys.executable, "-m", "mrss", "supervise", "logsdemo", "--no-tui",
         "--run-dir", str(run_dir)],
        env={**os.environ, "MRSS_PROJECTS": str(_project(tmp_path, keep))},
        stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        log = run_dir / "mrss.log"
        wait_until(lambda: log.exists() and "start flooder pid" in log.read_text(),
                   timeout=60, message="the flooder started")
        (run_dir / "flood.go").write_text("go")
        wait_until((run_dir / "flooder.flooded").exists, timeout=120,
                   message="the flood was logged to the end")
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=60) == 0
    finally:
        if proc.poll() is None:
            for child in psutil.Process(proc.pid).children(recursive=True):
                child.kill()
            proc.kill()
            proc.wait(timeout=10)
    return run_dir


@pytest.mark.slow
def test_supervise_rotates_the_log_and_its_readers_lose_nothing(tmp_path: Path) -> None:
    run_dir = _supervise_a_flood(tmp_path, keep=100)
    log = run_dir / "mrss.log"
    files = logfile.history_files(log)
    max_bytes = int(MAX_MB * logfile.MB)
    assert len(files) > 5, [f.name for f in files]  # rotated, many times
    assert files[-1] == log and files[0].name == f"mrss.log.{len(files) - 1}"
    assert all(f.stat().st_size <= logfile.OVERFULL * max_bytes + IN_FLIGHT for f in files)
    text = logfile.read_history(log)
    flood = [int(n) for n in re.findall(r"flooder\[\d+\] WARNING flood line (\d+)$", text,
                                        re.M)]
    assert sorted(flood) == list(range(FLOOD))  # every line once, none lost at a rotation
    assert "start flooder pid" in text and "all components stopped" in text
    # the chaos recorder reads the whole run, rotated files first
    writer = HistoryWriter(tmp_path / "history.jsonl")
    writer.write("campaign", t=0.0, project="logsdemo")
    recorder = Recorder(run_dir, writer, run_dir / "none.sqlite3")
    try:
        kept = recorder.record_log({"flooder"})
    finally:
        recorder.close()
        writer.close()
    history = load(tmp_path / "history.jsonl")
    assert history.log is not None and history.log.lines == kept
    lines = [x.message for x in history.loglines if x.component == "flooder"]
    assert sum(1 for m in lines if m.startswith("flood line ")) == FLOOD


@pytest.mark.slow
def test_supervise_keeps_the_log_within_keep_rotated_files(tmp_path: Path) -> None:
    run_dir = _supervise_a_flood(tmp_path, keep=2)
    log = run_dir / "mrss.log"
    files = logfile.history_files(log)
    max_bytes = int(MAX_MB * logfile.MB)
    assert [f.name for f in files] == ["mrss.log.2", "mrss.log.1", "mrss.log"]
    assert logfile.total_size(log) <= 3 * (logfile.OVERFULL * max_bytes + IN_FLIGHT)  # of 0.8 MB
    # the newest lines are all there, up to the root's last words
    text = logfile.read_history(log)
    flood = [int(n) for n in re.findall(r"flood line (\d+)$", text, re.M)]
    assert flood and flood == list(range(flood[0], FLOOD))
    assert "all components stopped" in text


WRITER = textwrap.dedent("""
    import logging, sys
    from mrss import logs
    logs.configure(sys.argv[1], console=False, file=sys.argv[2])
    for i in range(int(sys.argv[3])):
        logging.getLogger("mrss.w").info("%s %d %s", sys.argv[1], i, "x" * 200)
""")


LINES = 5000  # a writer's lines: 3 writers, about 4 MB in all


@pytest.mark.parametrize("keep", [1000, 2])
def test_processes_rotating_one_file_lose_no_line_and_stay_bounded(
        tmp_path: Path, keep: int) -> None:
    path = tmp_path / "mrss.log"
    rotation = logfile.Rotation(max_bytes=20_000, keep=keep)
    env = {**os.environ, logfile.ENV: rotation.to_env()}
    writers = [subprocess.Popen([sys.executable, "-c", WRITER, f"w{n}", str(path), str(LINES)],
                                env=env) for n in range(3)]
    for w in writers:
        assert w.wait(timeout=120) == 0
    files = logfile.history_files(path)
    assert 2 < len(files) <= keep + 1
    most = logfile.OVERFULL * rotation.max_bytes + IN_FLIGHT
    assert all(f.stat().st_size <= most for f in files)
    pattern = re.compile(r"\S+ \S+ (w\d)\[\d+\] INFO (w\d) (\d+) x{200}")
    seen: dict[str, list[int]] = {}
    for line in logfile.read_history(path).splitlines():
        m = pattern.fullmatch(line)
        assert m and m.group(1) == m.group(2), line[:120]  # whole lines, never mixed
        seen.setdefault(m.group(1), []).append(int(m.group(3)))
    if keep == 1000:  # all kept: every line of every writer, once
        assert {w: sorted(n) for w, n in seen.items()} == \
            {f"w{n}": list(range(LINES)) for n in range(3)}
    else:  # bounded: 3 files (of the 4 MB written); what is left of each writer is its
        assert logfile.total_size(path) <= 3 * most  # newest
        for numbers in seen.values():
            assert sorted(numbers) == list(range(min(numbers), LINES))


def test_the_dashboard_modes_pipe_is_copied_into_the_rotating_log(tmp_path: Path) -> None:
    path = tmp_path / "mrss.log"
    read_end, write_end = os.pipe2(os.O_CLOEXEC)
    pump = logfile.LogPump(read_end, logfile.LogFile(path, logfile.Rotation(2000, 100)))
    script = "import sys\nfor i in range(3000): print('raw', i, flush=i % 7 == 0)"
    try:
        subprocess.run([sys.executable, "-c", script], stdout=write_end, check=True,
                       timeout=60)
    finally:
        os.close(write_end)
    assert pump.join(timeout=30)
    files = logfile.history_files(path)  # 25,890 bytes in pieces of at most PIECE bytes:
    assert len(files) > 3  # at least 5 files
    assert all(f.stat().st_size <= 2000 + logfile.LogPump.PIECE for f in files)
    lines = logfile.read_history(path).splitlines()
    assert lines == [f"raw {i}" for i in range(3000)]  # whole lines, in order


def test_a_component_whose_stderr_is_piped_into_the_log_writes_each_record_once(
        tmp_path: Path) -> None:
    path = tmp_path / "mrss.log"
    script = textwrap.dedent("""
        import logging, sys
        from mrss import logs
        logs.configure("c", file=sys.argv[1])
        logging.getLogger("mrss.c").warning("only once")
        print("raw output", file=sys.stderr)
    """)
    read_end, write_end = os.pipe2(os.O_CLOEXEC)
    pump = logfile.LogPump(read_end, logfile.LogFile(path, logfile.Rotation(10**6, 2)))
    try:
        subprocess.run([sys.executable, "-c", script, str(path)], stderr=write_end,
                       env={**os.environ, "MRSS_STDERR_LOG": str(path)}, check=True,
                       timeout=60)
    finally:
        os.close(write_end)
    assert pump.join(timeout=30)
    text = path.read_text()
    assert text.count("only once") == 1 and "raw output" in text


def test_rotation_settings_come_from_logs_table_and_the_environment() -> None:
    default = logfile.Rotation.of_table({})
    assert default == logfile.Rotation(20 * logfile.MB, 5)
    assert logfile.Rotation.from_env({}) == default
    mine = logfile.Rotation.of_table({"max_mb": 0.5, "keep": 3})
    assert mine == logfile.Rotation(logfile.MB // 2, 3)
    assert logfile.Rotation.from_env({logfile.ENV: mine.to_env()}) == mine
    with pytest.raises(logfile.ConfigError, match="logs.keep"):
        logfile.Rotation.of_table({"keep": 0}, file="project.toml")
