"""MCAP recordings of a real bus: `mrss record` as a process, read back with the `mcap`
library's own readers, every message checked against its channel's schema."""

from __future__ import annotations

import json
import signal
from pathlib import Path

from mcap.reader import NonSeekingReader, make_reader

from mrss.bus import Publisher
from mrss.messages import KINDS, Percept, RobotData, decode
from mrss.recording.mcap_reader import McapRecording
from mrss.recording.schemas import LOCATION_FIX, all_kind_schemas
from mrss.testing import wait_until
from tests.commands.cli_bus import mrss, mrss_process, running_bus
from tests.recording.schema_check import problems


def mcap_percepts(path: Path) -> list[str]:
    """The percept literals in a recording's complete chunks, read by the mcap library's
    stream reader (it raises where a file still being written, or cut, ends)."""
    found: list[str] = []
    try:
        with path.open("rb") as handle:
            for _schema, channel, message in NonSeekingReader(handle).iter_messages(
                    log_time_order=False):  # file order: sorting would read to the end first
                if channel.topic == "percept":
                    found.append(json.loads(message.data)["body"]["literal"])
    except Exception:  # noqa: BLE001 - the end of a file being written or cut
        pass
    return found


def test_every_kind_has_a_schema_its_messages_conform_to() -> None:
    schemas = all_kind_schemas()
    assert set(schemas) == {f"mrss.{kind}" for kind in KINDS}
    status = schemas["mrss.action.status"]["properties"]["body"]
    assert status["properties"]["state"]["enum"][:1] and "succeeded" in \
        status["properties"]["state"]["enum"]
    assert status["required"] == ["uuid", "state"]
    assert problems({"v": 1, "id": "x", "ts": 1.0, "src": "s", "inc": 0, "kind": "percept",
                     "body": {"literal": "a", "op": "bogus", "extra": 1}},
                    schemas["mrss.percept"]) == ["$.body: unexpected property 'extra'"]


def test_a_sigkilled_recorder_leaves_a_file_readable_to_its_last_chunk(tmp_path: Path) -> None:
    out = tmp_path / "killed.mcap"
    with running_bus() as live, mrss_process("record", "--run-dir", str(live.run_dir),
                                             "--out", str(out)) as rec:
        rec.wait_line("recording ")
        with Publisher(live.endpoints, src="tester") as pub:
            counter = iter(range(1, 100_000))
            # the recorder's subscription is in place once a sync percept is in the file
            wait_until(lambda: pub.publish(Percept(literal=f"sync({next(counter)})"))
                       and mcap_percepts(out), 30, interval=0.1, message="a chunk written")
            for i in range(20):
                pub.publish(Percept(literal=f"before({i})"))
            wait_until(lambda: "before(19)" in mcap_percepts(out), 30, interval=0.1,
                       message="the percepts' chunk written")
        rec.proc.kill()
        rec.finish()
        assert rec.proc.returncode == -signal.SIGKILL

        # The mcap library reads every complete chunk, then stops at the missing footer.
        assert [p for p in mcap_percepts(out) if p.startswith("before(")] == [
            f"before({i})" for i in range(20)]
        with out.open("rb") as handle:
            recording = McapRecording(handle)
            percepts = [decode(*m.frames).body for m in _until_damage(recording)]
        assert Percept(literal="before(19)") in percepts

        info = mrss("recording", "info", str(out))
        assert info.returncode == 2
        assert "percept" in info.stdout and "Traceback" not in info.stderr
        assert f"at byte offset {out.stat().st_size}: the file ends before its footer" \
            in info.stderr

    with running_bus() as other:
        replay = mrss("replay", str(out), "--run-dir", str(other.run_dir),
                      "--as-fast-as-possible", "--prefix", "percept")
        assert replay.returncode == 2, replay.stderr
        assert f"({len(percepts)} messages before it were replayed)" in replay.stderr
        envs = [other.next() for _ in range(len(percepts))]
    assert [env.body for env in envs] == percepts
    assert all(env.replayed for env in envs)


def _until_damage(recording: McapRecording) -> list:  # type: ignore[type-arg]
    found = []
    try:
        for message in recording.recorded():
            found.append(message)
    except Exception:  # noqa: BLE001 - RecordingError at the cut
        pass
    return found
