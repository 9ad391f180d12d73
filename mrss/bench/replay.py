"""`mrss bench replay`: the dashboard's replay of a long mission (`mrss tui --replay`).

A recording of a busy mission (10 robots, telemetry at 2 Hz, batteries, an action a
robot every 30 s with its statuses, one failing in ten, log lines, heartbeats: about 33
messages a second) is written with the recorder's own MCAP writer; then measured: the
load (decoding every message), the index pass (keyframes, events, log lines), and seeks
of a headless replay dashboard (Textual's run_test, as `mrss tui --replay` builds it) to
random moments, back and forth. The reference, measured in the same run, is a seek
without keyframes (applying every message from the start), the cost keyframes avoid.
Target: a seek to any moment of a 30-minute mission in <= 100 ms (`SEEK_TARGET_S`).
"""

from __future__ import annotations

import asyncio
import random
import shutil
import statistics
import tempfile
import time
from pathlib import Path

from mrss.bench.report import BenchReport, Relation
from mrss.messages import (
    ActionRequest,
    ActionState,
    ActionStatus,
    Heartbeat,
    LogRecord,
    Message,
    RobotData,
    encode,
)
from mrss.recording.format import RecordedMessage
from mrss.recording.mcap_writer import McapRecordingWriter

MINUTES = 30.0
ROBOTS = 10
SEEKS = 20
SEEK_TARGET_S = 0.1
START = 1_700_000_000.0


def _messages_at(second: int) -> list[tuple[float, Message, str]]:
    t = START + second
    out: list[tuple[float, Message, str]] = []
    for r in range(ROBOTS):
        robot = f"r{r}"
        for half in (0.0, 0.5):
            out.append((t + half, RobotData(robot=robot, data={
                "type": "position", "lat": 47.0 + (second + half) * 1e-5 + r * 1e-3,
                "lon": 15.0, "heading": 90.0}), "rcl"))
        if second % 5 == r % 5:
            out.append((t, RobotData(robot=robot, data={"type": "battery",
                                                        "remaining": 100 - second / 60}),
                        "rcl"))
        if second % 30 == r:
            uuid = f"{robot}-{second}"
            failed = (second // 30) % 10 == 9
            out += [(t, ActionRequest(uuid=uuid, name="survey", args=[robot], robot=robot,
                                      goal=f"g{second}"), "reasoner"),
                    (t + 0.1, ActionStatus(uuid=uuid, state=ActionState.RUNNING, robot=robot,
                                           name="survey"), "rcl"),
                    (t + 20, ActionStatus(uuid=uuid, state=ActionState.FAILED if failed
                                          else ActionState.SUCCEEDED, robot=robot,
                                          name="survey", reason="stuck" if failed else ""),
                     "rcl")]
    out.append((t, LogRecord(component="rcl", level="INFO", message=f"tick {second}"), "rcl"))
    out.append((t, Heartbeat(component="rcl", pid=1), "rcl"))
    return out


def write_mission(path: Path, minutes: float) -> int:
    """A recording of `minutes` of the busy mission; how many messages it holds."""
    items = [m for second in range(int(minutes * 60)) for m in _messages_at(second)]
    items.sort(key=lambda item: item[0])
    with path.open("wb") as out:
        writer = McapRecordingWriter(out, created=START)
        for t, body, src in items:
            writer.write(RecordedMessage(t, encode(body, src=src)))
        writer.finish()
    return len(items)


async def _seeks(path: Path, keyframe_every: int | None, targets: list[float]
                 ) -> tuple[float, float, list[float]]:
    """(load s, index s, each seek's s) of a headless replay dashboard."""
    from mrss.tui.replay.app import ReplayApp
    from mrss.tui.replay.tape import Tape

    began = time.perf_counter()
    tape = Tape.load(path)
    loaded = time.perf_counter()
    extra = {} if keyframe_every is None else {"keyframe_every": keyframe_every}
    app = ReplayApp(tape, name=path.name, play=False, **extra)
    indexed = time.perf_counter()
    took: list[float] = []
    async with app.run_test(size=(200, 50)) as pilot:
        for target in targets:
            began_seek = time.perf_counter()
            app.seek_to(target)
            took.append(time.perf_counter() - began_seek)
            await pilot.pause()  # let it draw before the next
    return loaded - began, indexed - loaded, took


def run(quick: bool = False) -> BenchReport:
    minutes = 2.0 if quick else MINUTES
    report = BenchReport("replay", ["replay of", "messages", "MB", "load s", "index s",
                                    "seek mean ms", "seek max ms"], quick=quick)
    folder = Path(tempfile.mkdtemp(prefix="mrss-bench-replay-"))
    try:
        path = folder / "mission.mcap"
        count = write_mission(path, minutes)
        rng = random.Random(7)
        span = minutes * 60
        targets = [START + rng.uniform(0, span) for _ in range(SEEKS)] + [START + span]
        size = round(path.stat().st_size / 1e6, 1)
        load, index, seeks = asyncio.run(_seeks(path, None, targets))
        report.add_row(f"{minutes:g} min, keyframes", count, size, round(load, 2),
                       round(index, 2), round(statistics.mean(seeks) * 1e3, 1),
                       round(max(seeks) * 1e3, 1))
        _, plain_index, plain = asyncio.run(_seeks(path, 10**12, targets[-3:]))
        report.add_row(f"{minutes:g} min, from the start (reference)", count, size, "",
                       round(plain_index, 2), round(statistics.mean(plain) * 1e3, 1),
                       round(max(plain) * 1e3, 1))
        report.target(f"a seek to any moment of a {minutes:g}-minute mission in <= "
                      f"{SEEK_TARGET_S * 1e3:g} ms", max(seeks), Relation.AT_MOST,
                      SEEK_TARGET_S, "issue 32 (replay seek)")
        report.target("a keyframed seek takes at most half the time of one from the start "
                      "(mean of the last 3 seeks, ratio)",
                      statistics.mean(seeks[-3:]) / statistics.mean(plain), Relation.AT_MOST,
                      0.5, "reference: the same seeks without keyframes")
        report.notes.append(f"seek: app.seek_to on a headless replay dashboard (200 x 50): "
                            f"restore the keyframe before the target, apply the messages "
                            f"between, schedule every panel's redraw; {SEEKS} random "
                            f"moments and the end, back and forth")
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    return report
