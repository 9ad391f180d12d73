"""`mrss replay FILE --to-bus`: a recording republished onto a running bus (the engineers'
replay, next to the dashboard's `mrss tui --replay`); the former spelling without
`--to-bus` still replays, with a warning that shows the new one."""

from __future__ import annotations

from pathlib import Path

import pytest

from mrss.messages import Percept, RobotData, encode
from mrss.recording.format import RecordedMessage
from mrss.recording.mcap_writer import McapRecordingWriter
from tests.commands.cli_bus import mrss, running_bus

BODIES = [Percept(literal="fire(z1)"), RobotData(robot="ugv1", data={"lat": 1.0, "lon": 2.0}),
          Percept(literal="fire(z2)")]


def recording(path: Path) -> None:
    with path.open("wb") as out:
        writer = McapRecordingWriter(out, created=1.0)
        for i, body in enumerate(BODIES):
            writer.write(RecordedMessage(1.0 + i, encode(body, src="tester")))
        writer.finish()


@pytest.mark.parametrize("spelling", [["--to-bus"], []])
def test_replay_to_bus_republishes_and_the_former_spelling_warns(
        tmp_path: Path, spelling: list[str]) -> None:
    path = tmp_path / "r.mcap"
    recording(path)
    with running_bus() as bus:
        done = mrss("replay", str(path), *spelling, "--run-dir", str(bus.run_dir),
                    "--as-fast-as-possible")
        assert done.returncode == 0, done.stderr
        envs = [bus.next() for _ in BODIES]
    assert [env.body for env in envs] == BODIES and all(env.replayed for env in envs)
    warned = f"say: mrss replay {path} --to-bus" in done.stderr
    assert warned == (not spelling), done.stderr
    assert "Traceback" not in done.stderr
