"""The Foxglove component: a WebSocket client speaking the Foxglove protocol subscribes to
a robot's channel of a running project and receives its positions while it drives; the
bridge's channels, schemas and messages are those of an MCAP recording; a host beyond
loopback is refused."""

from __future__ import annotations

import io
import json
import shutil
from contextlib import closing
from pathlib import Path

import foxglove
import pytest
from mcap.reader import make_reader

from mrss.actors.foxglove.bridge import FoxgloveBridge
from mrss.actors.foxglove.layout import mission_layout
from mrss.actors.foxglove.service import URL_FILE, FoxgloveComponent
from mrss.api import distance_m
from mrss.api.testing import RunningProject
from mrss.errors import ConfigError
from mrss.messages import ActionStatus, Command, LogRecord, Percept, RobotData, encode
from mrss.recording.format import RecordedMessage
from mrss.recording.mcap_writer import McapRecordingWriter
from mrss.recording.schemas import LOCATION_FIX
from mrss.runtime.component import ComponentContext
from tests.actors.foxglove.foxglove_client import FoxgloveClient

TEMPLATE_SIMS = Path(__file__).resolve().parents[3] / "projects" / "template_sims"
UGV_TARGET = (48.2086, 16.3742)
FOXGLOVE_TABLE = """
[components.foxglove]
kind = "foxglove"
port = 0
"""


@pytest.mark.slow
def test_a_foxglove_client_receives_a_driving_robots_positions(tmp_path: Path) -> None:
    project = tmp_path / "template_sims"
    shutil.copytree(TEMPLATE_SIMS, project, ignore=shutil.ignore_patterns("__pycache__"))
    with (project / "project.toml").open("a", encoding="utf-8") as toml:
        toml.write(FOXGLOVE_TABLE)
    system = RunningProject(project, tmp_path / "run", env={"MRSS_SIM_SPEEDUP": "20"})
    with closing(system.start(timeout=60.0)):  # generous: a busy machine starts slowly
        system.wait_ready()
        url_file = tmp_path / "run" / URL_FILE
        system.wait_for(url_file.is_file, 30, "the Foxglove server's URL")
        url = url_file.read_text().strip()
        assert url.startswith("ws://127.0.0.1:")
        client = FoxgloveClient.open(url)
        try:
            client.wait(lambda: client.server, 30, "the server's serverInfo")
            assert client.server["name"] == "mrss template_sims"
            topic = "robot.ugv1.location"
            client.wait(lambda: topic in client.channels, 30, "the UGV's location channel")
            channel = client.channels[topic]
            assert channel["schemaName"] == LOCATION_FIX and channel["encoding"] == "json"
            assert json.loads(channel["schema"])["title"] == LOCATION_FIX
            client.subscribe(7, topic)
            client.wait(lambda: client.received.get(7), 30, "a first position")

            system.publish("mrss/ui/goto", {"goal": "g1", "robot": "ugv1",
                                            "lat": UGV_TARGET[0], "lon": UGV_TARGET[1]})
            client.wait(lambda: system.statuses("ugv1", "succeeded"), 90, "the UGV's drive")
            first = client.received[7][0][1]
            client.wait(lambda: distance_m(client.received[7][-1][1]["latitude"],
                                           client.received[7][-1][1]["longitude"],
                                           *UGV_TARGET) < 10.0, 30,
                        "a position at the drive's end")
        finally:
            client.close()
        fixes = [fix for _, fix in client.received[7]]
        assert all(f["frame_id"] == "ugv1" for f in fixes)
        assert len({(f["latitude"], f["longitude"]) for f in fixes}) >= 3  # it moved
        assert distance_m(first["latitude"], first["longitude"], *UGV_TARGET) > 10.0
        times = [t for t, _ in client.received[7]]
        assert times == sorted(times)
        assert system.interrupt() == 0, system.log()


def test_the_bridge_sends_the_channels_schemas_and_messages_of_a_recording(
        tmp_path: Path) -> None:
    messages = [
        RecordedMessage(10.0, encode(Percept(literal="fire(z1)"), src="events")),
        RecordedMessage(11.0, encode(RobotData(robot="ugv1", data={"lat": 1.5, "lon": 2.5,
                                                                   "battery": 80.0}),
                                     src="rcl")),
        RecordedMessage(12.0, encode(ActionStatus(uuid="u1", state="running"), src="rcl")),
        RecordedMessage(13.0, (b"percept", b"\xc1 not msgpack"), "not msgpack: FormatError"),
        RecordedMessage(14.0, encode(RobotData(robot="ugv1", data={"lat": 1.6, "lon": 2.5}),
                                     src="rcl")),
        # a hotspot the UGV reports is not where it is; an operator's session is a secret
        RecordedMessage(15.0, encode(RobotData(robot="ugv1", data={
            "type": "hotspot", "id": 1, "lat": 9.0, "lon": 9.0}), src="rcl")),
        RecordedMessage(16.0, encode(Command(command="pause"), src="tui",
                                     op="session-secret")),
    ]
    recorded = io.BytesIO()
    writer = McapRecordingWriter(recorded, created=1.0)
    context = foxglove.Context()
    sink = foxglove.open_mcap(tmp_path / "bridge.mcap", context=context)  # a subscriber
    bridge = FoxgloveBridge(context)
    for message in messages:
        writer.write(message)
        bridge.write(message)
    writer.finish()
    sink.close()

    def contents(source: io.BufferedIOBase | io.BytesIO) -> list[tuple[str, str, bytes, int,
                                                                       bytes]]:
        return [(channel.topic, schema.name, schema.data, message.log_time, message.data)
                for schema, channel, message in make_reader(source).iter_messages()
                if schema is not None]

    recorded.seek(0)
    with (tmp_path / "bridge.mcap").open("rb") as sent:
        assert contents(sent) == contents(recorded)
    recorded.seek(0)
    topics = {t for t, *_ in contents(recorded)}
    assert {"percept", "robot.ugv1.location", "mrss.malformed"} <= topics
    assert bridge.count == len(messages)
    recorded.seek(0)
    sent_data = [data for *_, data in contents(recorded)]
    assert not [d for d in sent_data if b"session-secret" in d]
    recorded.seek(0)
    fixes = [json.loads(d)["latitude"] for t, *_, d in contents(recorded)
             if t == "robot.ugv1.location"]
    assert fixes == [1.5, 1.6]


@pytest.mark.parametrize("host", ["0.0.0.0", "192.168.1.20", "command-post"])
def test_a_host_beyond_loopback_is_refused(tmp_path: Path, host: str) -> None:
    ctx = ComponentContext(name="foxglove", incarnation=1, project_dir=tmp_path,
                           run_dir=tmp_path, options={"host": host})
    with pytest.raises(ConfigError) as refused:
        FoxgloveComponent().start(ctx)
    text = str(refused.value)
    assert "components.foxglove.host" in text and "cannot authenticate" in text
    assert "ssh -L" in text
    assert not (tmp_path / URL_FILE).exists()


def test_a_wrong_port_names_its_key(tmp_path: Path) -> None:
    ctx = ComponentContext(name="fg", incarnation=1, project_dir=tmp_path, run_dir=tmp_path,
                           options={"port": "8765"})
    with pytest.raises(ConfigError, match="components.fg.port"):
        FoxgloveComponent().start(ctx)


DOCS_LAYOUT = Path(__file__).resolve().parents[3] / "docs" / "foxglove-layout.json"


def layout_topics(node: object) -> set[str]:
    """Every topic a layout names: map follow topics, plot and raw-message paths."""
    found: set[str] = set()
    if isinstance(node, dict):
        for key, value in node.items():
            if key in ("followTopic", "topicPath", "value") and isinstance(value, str):
                found.add(value.split('"')[1] if value.startswith('"') else value)
            else:
                found |= layout_topics(value)
    elif isinstance(node, list):
        for item in node:
            found |= layout_topics(item)
    return found


def test_the_documented_layout_is_the_one_built_and_names_only_recorded_channels(
        tmp_path: Path) -> None:
    documented = json.loads(DOCS_LAYOUT.read_text(encoding="utf-8"))
    assert documented == json.loads(mission_layout(["uav1", "ugv1"]).to_json())
    panels = json.dumps(documented)
    for panel in ("Map", "Plot", "RawMessages"):
        assert f'"panelType": "{panel}"' in panels
    # the channels a wildfire recording has of these topics (the bridge's are the same)
    recorded = io.BytesIO()
    writer = McapRecordingWriter(recorded, created=1.0)
    for body, src in [(RobotData(robot="uav1", data={"type": "position", "lat": 1.0,
                                                     "lon": 2.0, "relative_alt": 30.0}), "rcl"),
                      (RobotData(robot="ugv1", data={"type": "position", "lat": 1.0,
                                                     "lon": 2.0}), "rcl"),
                      (ActionStatus(uuid="u1", state="running"), "rcl"),
                      (Percept(literal="fire(z1)"), "events"),
                      (LogRecord(component="reasoner", level="INFO", message="hi"),
                       "reasoner")]:
        writer.write(RecordedMessage(1.0, encode(body, src=src)))
    writer.finish()
    recorded.seek(0)
    summary = make_reader(recorded).get_summary()
    assert summary is not None
    channels = {channel.topic for channel in summary.channels.values()}
    assert layout_topics(documented) <= channels, layout_topics(documented) - channels
