"""The recording's `world.geojson` channel: the world model's shapes, as its real answers
on the bus show them, written as Foxglove GeoJSON whenever they change."""

from __future__ import annotations

import io
import json
from typing import Any

from mcap.reader import make_reader

from mrss.actors.worldmodel.model import WorldModel
from mrss.actors.worldmodel.store import WorldModelStore
from mrss.messages import DataRequest, Message, encode
from mrss.recording import geojson
from mrss.recording.mcap_writer import McapRecordingWriter
from mrss.world import topics
from mrss.world.objects import Position, WorldObject
from tests.recording.schema_check import problems

AREA = {"type": "Polygon", "coordinates": [[[16.0, 48.0], [16.1, 48.0], [16.1, 48.1],
                                            [16.0, 48.0]]]}


def test_the_topics_are_the_world_models() -> None:
    assert geojson.WM_REQUEST_TOPIC == topics.WM_REQUEST_TOPIC
    assert geojson.WM_REPLY_TOPIC == topics.WM_REPLY_TOPIC


class Bus:
    """Requests to a real world model and its answers, as the recorder receives them."""

    def __init__(self) -> None:
        self.world = WorldModel(WorldModelStore())
        self.out = io.BytesIO()
        self.writer = McapRecordingWriter(self.out, created=1.0)
        self.t = 1.0
        self.serial = 0

    def _send(self, body: Message, topic: str) -> None:
        self.t += 1
        self.writer.received(self.t, list(encode(body, src="dl", inc=1, topic=topic)))

    def ask(self, function: str, *args: Any) -> None:
        self.serial += 1
        request = DataRequest(request_id=f"r{self.serial}", function=function, args=list(args))
        self._send(request, topics.WM_REQUEST_TOPIC)
        self._send(self.world.handle(request), topics.wm_reply_topic("dl"))

    def collections(self) -> list[dict[str, Any]]:
        self.writer.finish()
        reader = make_reader(io.BytesIO(self.out.getvalue()))
        found = []
        for schema, _, message in reader.iter_messages(topics=[geojson.GEOJSON_TOPIC]):
            assert schema is not None and schema.name == "foxglove.GeoJSON"
            value = json.loads(message.data)
            assert problems(value, json.loads(schema.data)) == []
            found.append(json.loads(value["geojson"]))
        return found


def _shapes(collection: dict[str, Any]) -> dict[str, tuple[str, Any]]:
    assert collection["type"] == "FeatureCollection"
    return {f["id"]: (f["geometry"]["type"], f["properties"]) for f in collection["features"]}


def test_areas_and_objects_are_written_whenever_they_change_robots_left_out() -> None:
    bus = Bus()
    bus.ask("wm.upsert", {"id": "a1", "kind": "area", "geometry": AREA,
                          "attributes": {"priority": 3}})
    bus.ask("wm.upsert", {"id": "uav1", "kind": "robot",
                          "position": {"lat": 48.05, "lon": 16.05}})  # not a shape here
    bus.ask("wm.upsert_many", [{"id": "hs1", "kind": "hotspot",
                                "position": {"lat": 48.02, "lon": 16.03}},
                               {"id": "bad", "kind": "Not A Kind"}])  # refused: left out
    bus.ask("wm.upsert", {"id": "hs1", "kind": "hotspot",
                          "attributes": {"state": "supplied"}})  # merged by the world model
    bus.ask("wm.list")  # the same objects again: no change, nothing written
    bus.ask("wm.upsert", {"id": "a1", "kind": "area"})  # keeps its shape: no change
    bus.ask("wm.delete", "a1")
    bus.ask("wm.delete", "nothing")  # answered false: no change
    found = [_shapes(c) for c in bus.collections()]
    assert found[0] == {"a1": ("Polygon", {"id": "a1", "kind": "area", "priority": 3})}
    assert found[1]["hs1"] == ("Point", {"id": "hs1", "kind": "hotspot"})
    assert "bad" not in found[1] and "uav1" not in found[1]
    assert found[2]["hs1"] == ("Point", {"id": "hs1", "kind": "hotspot",
                                         "state": "supplied"})
    assert found[-1] == {"hs1": found[2]["hs1"]}  # a1 deleted
    assert len(found) == 4  # area, hotspot, its state, the deletion


def test_a_refused_write_and_an_unanswered_request_change_nothing() -> None:
    bus = Bus()
    bus.ask("wm.upsert", {"id": "z1", "kind": "zone", "geometry": {"type": "Polygon"}})
    bus.writer.received(9.0, list(encode(DataRequest(request_id="lost", function="wm.upsert",
                                                     args=[{"id": "z2", "kind": "zone",
                                                            "geometry": AREA}]),
                                         src="dl", topic=topics.WM_REQUEST_TOPIC)))
    assert bus.collections() == []


def test_the_seed_appears_once_listed() -> None:
    bus = Bus()
    bus.world.upsert(WorldObject("base", "base", Position(48.0, 16.0)))  # not on the bus
    bus.ask("wm.get", "nothing")
    bus.ask("wm.list")
    found = bus.collections()
    assert [_shapes(c) for c in found] == [{"base": ("Point", {"id": "base", "kind": "base"})}]
