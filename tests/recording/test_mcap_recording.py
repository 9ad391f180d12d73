"""MCAP recordings of a real bus: `mrss record` as a process, read back with the `mcap`
library's own readers, every message checked against its channel's schema."""

from __future__ import annotations

import json
import signal
from pathlib import Path

import pytest
from mcap.reader import NonSeekingReader, make_reader

from mrss import __version__ as mrss_version
from mrss.api import distance_m
from mrss.api.testing import RunningProject
from mrss.bus import Publisher
from mrss.messages import KINDS, Percept, decode
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


TEMPLATE_SIMS = Path(__file__).resolve().parents[2] / "projects" / "template_sims"
UGV_TARGET = (48.2086, 16.3742)


@pytest.mark.slow
def test_a_supervised_projects_recording_decodes_against_its_schemas(tmp_path: Path) -> None:
    out = tmp_path / "mission.mcap"
    with RunningProject(TEMPLATE_SIMS, tmp_path / "run", env={"MRSS_SIM_SPEEDUP": "20"}) as system:
        with mrss_process("record", "--run-dir", str(system.run_dir), "--out", str(out),
                          "--project", str(TEMPLATE_SIMS), "--timeout", "30") as rec:
            rec.wait_line("recording ", timeout=30)
            system.wait_ready()
            system.publish("mrss/ui/goto", {"goal": "g1", "robot": "ugv1",
                                            "lat": UGV_TARGET[0], "lon": UGV_TARGET[1]})
            system.wait_for(lambda: system.statuses("ugv1", "succeeded"), 90, "the UGV's drive")
            rec.proc.send_signal(signal.SIGINT)
            assert rec.finish() == 0, rec.stderr()
        assert system.interrupt() == 0

    with out.open("rb") as handle:
        reader = make_reader(handle)
        summary = reader.get_summary()
        assert summary is not None and summary.chunk_indexes  # indexed: seeking reads no data
        messages = list(reader.iter_messages(log_time_order=False))
        by_kind: dict[str, int] = {}
        positions, fixes = [], []
        for schema, channel, message in messages:
            assert schema is not None and schema.encoding == "jsonschema"
            value = json.loads(message.data)
            assert problems(value, json.loads(schema.data)) == [], (channel.topic, value)
            by_kind[schema.name] = by_kind.get(schema.name, 0) + 1
            if schema.name == "mrss.robot.data" and value["body"]["robot"] == "ugv1" \
                    and "lat" in value["body"]["data"]:
                data = value["body"]["data"]
                positions.append((message.publish_time, data["lat"], data["lon"]))
            elif schema.name == LOCATION_FIX and channel.topic == "robot.ugv1.location":
                fixes.append((message.publish_time, value["latitude"], value["longitude"]))
        assert {"mrss.action.request", "mrss.action.status", "mrss.percept",
                "mrss.sup.heartbeat", LOCATION_FIX} <= set(by_kind)
        assert fixes == positions and fixes[0][1:] != fixes[-1][1:]  # it moved
        assert distance_m(*fixes[-1][1:], *UGV_TARGET) < 10.0  # the drive's end is in it

        # Seeking: from a time in the middle, the index gives that message first.
        ordered = sorted(messages, key=lambda m: m[2].log_time)
        _, channel, middle = ordered[len(ordered) // 2]
        _, _, first = next(iter(reader.iter_messages(starting_at=middle.log_time)))
        assert first.log_time == middle.log_time
        later = list(reader.iter_messages(topics=[channel.topic], starting_at=middle.log_time))
        assert later[0][2].log_time == middle.log_time
        assert middle.data in [m.data for _, _, m in later if m.log_time == middle.log_time]
        assert len(later) == sum(1 for _, c, m in messages
                                 if c.topic == channel.topic and m.log_time >= middle.log_time)

        metadata = {m.name: m.metadata for m in reader.iter_metadata()}
        assert metadata["project"]["name"] == "template_sims"
        assert metadata["project"]["project.toml"] == (TEMPLATE_SIMS / "project.toml").read_text()
        assert metadata["mrss"]["version"] == mrss_version
        assert metadata["incarnations"]["rcl"] == "1"
        attachments = {a.name: a.data for a in reader.iter_attachments()}
        assert attachments["agent.asl"] == (TEMPLATE_SIMS / "agent.asl").read_bytes()

    info = mrss("recording", "info", str(out))
    assert info.returncode == 0, info.stderr
    assert "project:   template_sims" in info.stdout
    assert f"messages:  {len(messages)} on " in info.stdout
    csv_out = tmp_path / "fixes.csv"
    export = mrss("recording", "export", str(out), "--topic", "robot.ugv1.location",
                  "--format", "csv", "--out", str(csv_out))
    assert export.returncode == 0, export.stderr
    rows = csv_out.read_text().splitlines()
    assert rows[0].startswith("topic,log_time,publish_time,timestamp.sec")
    assert len(rows) == len(fixes) + 1
