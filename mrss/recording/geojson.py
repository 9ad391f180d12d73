"""The world model's areas, zones and objects, as the bus shows them, for Foxglove's map.

The world model is asked on `dl.request.wm` and answers on `dl.reply.wm[.<src>]`
(mrss/world/topics.py). `WorldShapes` follows both: an object in an answer (`wm.get`,
`wm.list`, `wm.near`, ..., the `object` of an answered `wm.upsert`), an object written by
a request the world model accepted (`wm.upsert`, `wm.upsert_many`; only the answer says
it was), and a `wm.delete` answered true. Robots are left out (they have their
LocationFix channels), and so are objects with no shape. Whenever the shapes change, the
recorder writes them all, one GeoJSON FeatureCollection, to `world.geojson` as Foxglove's
`foxglove.GeoJSON`: the Map panel shows the latest one, so it shows the world as it
was at that time of the recording. The seed (world.json) appears once someone lists it
on the bus (the dashboard's map does).
"""

from __future__ import annotations

import json
from collections import OrderedDict
from typing import Any

from mrss.messages import DataReply, DataRequest, Message

# mrss/world/topics.py's WM_REQUEST_TOPIC and WM_REPLY_TOPIC (a layer above this one;
# tests/recording/test_geojson.py keeps them equal).
WM_REQUEST_TOPIC = "dl.request.wm"
WM_REPLY_TOPIC = "dl.reply.wm"
GEOJSON_TOPIC = "world.geojson"
GEOJSON = "foxglove.GeoJSON"
# Foxglove's well-known schema (foxglove/schemas, jsonschema/GeoJSON.json).
GEOJSON_SCHEMA = {
    "title": GEOJSON,
    "description": "GeoJSON data for annotating maps",
    "type": "object",
    "properties": {
        "geojson": {"type": "string",
                    "description": "GeoJSON data encoded as a UTF-8 string"},
    },
}
PENDING = 10_000  # requests remembered until answered (most are, within a second)
_READS = frozenset({"wm.get", "wm.list", "wm.near", "wm.intersecting", "wm.within",
                    "wm.within_distance"})
_WRITES = frozenset({"wm.upsert", "wm.upsert_many", "wm.delete"})


def feature(obj: Any) -> dict[str, Any] | None:
    """A world model object (its JSON) as a GeoJSON Feature; None for a robot, an
    object without a shape, or anything that is not an object."""
    if not isinstance(obj, dict) or not isinstance(obj.get("id"), str):
        return None
    kind = obj.get("kind")
    if not isinstance(kind, str) or kind == "robot":
        return None
    geometry = obj.get("geometry")
    position = obj.get("position")
    if not isinstance(geometry, dict):
        if not (isinstance(position, dict) and _number(position.get("lat"))
                and _number(position.get("lon"))):
            return None
        geometry = {"type": "Point", "coordinates": [position["lon"], position["lat"]]}
    attributes = obj.get("attributes")
    properties = {"id": obj["id"], "kind": kind,
                  **(attributes if isinstance(attributes, dict) else {})}
    return {"type": "Feature", "id": obj["id"], "geometry": geometry,
            "properties": properties}


def _number(value: Any) -> bool:
    return type(value) in (int, float)


class WorldShapes:
    """The shapes of the world model's objects as far as the bus has shown them."""

    def __init__(self) -> None:
        self._pending: OrderedDict[str, DataRequest] = OrderedDict()
        self._features: dict[str, dict[str, Any]] = {}

    def seen(self, topic: str, body: Message) -> bool:
        """Take one bus message; whether the shapes changed."""
        if isinstance(body, DataRequest):
            if topic == WM_REQUEST_TOPIC and body.function in _READS | _WRITES:
                self._pending[body.request_id] = body
                if len(self._pending) > PENDING:
                    self._pending.popitem(last=False)
            return False
        if isinstance(body, DataReply) and topic.startswith(WM_REPLY_TOPIC):
            request = self._pending.pop(body.request_id, None)
            if request is not None and body.ok:
                return self._answered(request, body.result)
        return False

    def _answered(self, request: DataRequest, result: Any) -> bool:
        function, args = request.function, request.args
        if function == "wm.delete":
            return bool(result) and bool(args) and \
                self._features.pop(str(args[0]), None) is not None
        if function == "wm.upsert":
            written = result.get("object") if isinstance(result, dict) else None
            return self._put([written if written is not None else (args or [None])[0]])
        if function == "wm.upsert_many":
            entries = args[0] if args and isinstance(args[0], list) else []
            results = result if isinstance(result, list) else []
            # one result per entry, in order (a refused entry's has an "error")
            return self._put([r.get("object", entry) for r, entry
                              in zip(results, entries, strict=False)
                              if isinstance(r, dict) and "error" not in r])
        return self._put(result if isinstance(result, list) else [result])

    def _put(self, objects: list[Any]) -> bool:
        changed = False
        for obj in objects:
            if isinstance(obj, dict) and obj.get("kind") == "robot":
                continue
            found = feature(obj)
            if found is None:
                # A write of attributes alone (no shape given): keep the shape, merge them.
                old = self._features.get(str(obj.get("id"))) if isinstance(obj, dict) else None
                attributes = obj.get("attributes") if isinstance(obj, dict) else None
                if old is None or not isinstance(attributes, dict):
                    continue
                found = {**old, "properties": {**old["properties"], **attributes}}
            if self._features.get(found["id"]) != found:
                self._features[found["id"]] = found
                changed = True
        return changed

    def collection(self) -> dict[str, Any]:
        """The shapes as a `foxglove.GeoJSON` message (a FeatureCollection, by id)."""
        features = [self._features[key] for key in sorted(self._features)]
        return {"geojson": json.dumps({"type": "FeatureCollection", "features": features},
                                      separators=(",", ":"))}
