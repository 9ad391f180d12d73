"""The world model as a recording saw it: its objects rebuilt from the writes on the bus.

A recording holds the world model's requests (`wm.upsert`, `wm.upsert_many`, `wm.delete`
on `dl.request.wm`) and their answers, not the world model itself. `RecordedWorld`
applies them as the store does (an upsert merges attributes into the object it updates;
an answer's `object` is the stored one and replaces it; a `wm.list` answer replaces
everything), so the dashboard's map can show, at any moment of a replay, the objects
the world model held then. The seed objects of the world model (loaded from a file at
its start) are not on the bus: they appear only if the recording holds a `wm.list`
answer (a dashboard was attached while recording).
"""

from __future__ import annotations

import copy
from enum import IntEnum
from typing import Any

from mrss.messages import DataReply, DataRequest, Envelope
from mrss.world.topics import WM_REQUEST_TOPIC

WRITES = ("wm.upsert", "wm.upsert_many", "wm.delete")
ASKED_LIMIT = 10_000  # requests kept waiting for their answer


class WorldChange(IntEnum):
    """What a message changed of the objects, least to most (the map redraws on SHAPE at
    once, POSITION now and then)."""

    NONE = 0
    POSITION = 1  # only objects' positions moved
    SHAPE = 2  # an object came, went, or changed otherwise


def _merge(old: dict[str, Any] | None, new: dict[str, Any]) -> dict[str, Any]:
    """`new` written over `old` as the store does: keys replaced, attributes merged."""
    if old is None:
        return copy.deepcopy(new)
    merged = {**old, **copy.deepcopy(new)}
    if new.get("position") is None and new.get("geometry") is None:
        merged["position"], merged["geometry"] = old.get("position"), old.get("geometry")
    else:  # a new shape replaces the stored one (a point may become an area)
        merged["position"], merged["geometry"] = new.get("position"), new.get("geometry")
    attributes = new.get("attributes")
    if isinstance(attributes, dict) and isinstance(old.get("attributes"), dict):
        merged["attributes"] = {**old["attributes"], **attributes}
    return merged


class RecordedWorld:
    """Objects by id, as the recorded writes left them; `apply` says what changed."""

    def __init__(self) -> None:
        self.objects: dict[str, dict[str, Any]] = {}
        self._asked: dict[str, str] = {}  # request id -> function, until answered

    def apply(self, env: Envelope) -> WorldChange:
        """Take one bus message; what it changed."""
        body = env.body
        if isinstance(body, DataRequest) and env.topic == WM_REQUEST_TOPIC:
            if body.function in (*WRITES, "wm.list"):
                self._asked[body.request_id] = body.function
                if len(self._asked) > ASKED_LIMIT:  # unanswered ones (writes not waited for)
                    del self._asked[next(iter(self._asked))]
            return self._request(body)
        if isinstance(body, DataReply) and body.ok:
            function = self._asked.pop(body.request_id, "")
            if function == "wm.list" and isinstance(body.result, list):
                return self._replace(body.result)
            if function in ("wm.upsert", "wm.upsert_many"):
                results = body.result if isinstance(body.result, list) else [body.result]
                return self._stored([r.get("object") for r in results if isinstance(r, dict)])
        return WorldChange.NONE

    def listing(self) -> list[dict[str, Any]]:
        """Every object, as a `wm.list` answer gives them."""
        return list(self.objects.values())

    def _request(self, request: DataRequest) -> WorldChange:
        args = request.args
        if request.function == "wm.upsert" and len(args) == 1:
            return self._write([args[0]])
        if request.function == "wm.upsert_many" and len(args) == 1 and isinstance(args[0], list):
            return self._write(list(args[0]))
        if request.function == "wm.delete" and len(args) == 1 and isinstance(args[0], str):
            gone = self.objects.pop(args[0], None) is not None
            return WorldChange.SHAPE if gone else WorldChange.NONE
        return WorldChange.NONE

    def _write(self, entries: list[Any]) -> WorldChange:
        change = WorldChange.NONE
        for entry in entries:
            if not isinstance(entry, dict) or not isinstance(entry.get("id"), str):
                continue  # the world model refused it too
            old = self.objects.get(entry["id"])
            new = _merge(old, entry)
            change = max(change, _difference(old, new))
            self.objects[entry["id"]] = new
        return change

    def _stored(self, objects: list[Any]) -> WorldChange:
        change = WorldChange.NONE
        for obj in objects:
            if isinstance(obj, dict) and isinstance(obj.get("id"), str):
                old = self.objects.get(obj["id"])
                change = max(change, _difference(old, obj))
                self.objects[obj["id"]] = copy.deepcopy(obj)
        return change

    def _replace(self, objects: list[Any]) -> WorldChange:
        fresh = {o["id"]: copy.deepcopy(o) for o in objects
                 if isinstance(o, dict) and isinstance(o.get("id"), str)}
        change = WorldChange.SHAPE if set(fresh) != set(self.objects) else WorldChange.NONE
        for ident, obj in fresh.items():
            change = max(change, _difference(self.objects.get(ident), obj))
        self.objects = fresh
        return change


BOOKKEEPING = ("version", "updated")  # the store's, not what the map shows


def _difference(old: dict[str, Any] | None, new: dict[str, Any]) -> WorldChange:
    if old is None:
        return WorldChange.SHAPE
    before = {k: v for k, v in old.items() if k not in BOOKKEEPING and v is not None}
    after = {k: v for k, v in new.items() if k not in BOOKKEEPING and v is not None}
    if before == after:
        return WorldChange.NONE
    before.pop("position", None)
    after.pop("position", None)
    return WorldChange.POSITION if before == after else WorldChange.SHAPE

