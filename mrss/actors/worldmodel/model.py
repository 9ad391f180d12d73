"""The embedded world model as a service: store + rules + percepts, and its bus functions.

Every write goes through `WorldModel.upsert` (or `upsert_many`, a batch in one
transaction), whichever way it came (bus, HTTP, seed), so project rules fire for all of
them and their literals are emitted as percepts.
On the bus the world model answers `DataRequest`s on `dl.request.wm` with `DataReply`s
on `dl.reply.wm`; functions: `wm.get(id)`, `wm.list(kind)`, `wm.upsert(object)`,
`wm.upsert_many(objects)` (one reply, after the commit, with a result per object in
order: what `wm.upsert` gives, or {"error": text} for an invalid object),
`wm.near(lat, lon, radius_m, kind)`, `wm.delete(id)`, and the spatial predicates over a
GeoJSON geometry: `wm.intersecting(geometry, kind)`, `wm.within(geometry, kind)`,
`wm.within_distance(geometry, distance_m, kind)` (nearest first, with distance_m).

Project configuration (`[worldmodel]` of project.toml):
    seed = "world.json"          # objects loaded at start (a JSON list), in the project folder
    rules_module = "worldmodel.py"  # defines rules(options) -> list[Rule]; default if present
    [[worldmodel.rules]]         # built-in rules, no code needed
    type = "no_object_within"; kind = "hotspot"; other = "water_source"
    radius_m = 500; functor = "hotspot_detected"
"""

from __future__ import annotations

import json
import logging
import threading
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from mrss.actors.worldmodel.options import values_of
from mrss.actors.worldmodel.rules import NoObjectWithin, Rule, RuleEngine
from mrss.actors.worldmodel.store import (
    Change,
    Geometry,
    Position,
    WorldObject,
    WorldStore,
    WorldStoreUnavailable,
)
from mrss.errors import ConfigError
from mrss.messages import DataReply, DataRequest
from mrss.runtime.datalayer_client import NO_WAIT
from mrss.runtime.loader import import_project_module, project_file
from mrss.world.topics import UNAVAILABLE_PREFIX

log = logging.getLogger("mrss.worldmodel")


class WorldModel:
    """The store, its rules, and where rule literals go (`emit(literal)`)."""

    def __init__(self, store: WorldStore, rules: RuleEngine | None = None,
                 emit: Callable[[str], None] | None = None) -> None:
        self.store = store
        self.rules = rules or RuleEngine()
        self._emit = emit
        self._write = threading.Lock()
        self.requests = 0
        self.request_errors = 0

    def get(self, object_id: str) -> WorldObject | None:
        """The object with this id, or None."""
        return self.store.get(object_id)

    def objects(self, kind: str | None = None) -> list[WorldObject]:
        """All objects, or those of a kind."""
        return self.store.objects(kind)

    def near(self, position: Position, radius_m: float,
             kind: str | None = None) -> list[tuple[WorldObject, float]]:
        """Objects within `radius_m` metres of `position`, nearest first."""
        return self.store.near(position, radius_m, kind)

    def intersecting(self, geometry: Geometry, kind: str | None = None) -> list[WorldObject]:
        """Objects whose shape shares a point with `geometry`."""
        return self.store.intersecting(geometry, kind)

    def within(self, geometry: Geometry, kind: str | None = None) -> list[WorldObject]:
        """Objects whose shape lies inside `geometry`."""
        return self.store.within(geometry, kind)

    def within_distance(self, geometry: Geometry, distance_m: float,
                        kind: str | None = None) -> list[tuple[WorldObject, float]]:
        """Objects within `distance_m` metres of `geometry`, nearest first."""
        return self.store.within_distance(geometry, distance_m, kind)

    def upsert(self, obj: WorldObject, *, replace_attributes: bool = False,
               deferred: bool = False) -> Change:
        """Store `obj`, then run the rules and emit what they produce. `deferred`: a write
        nobody waits for (telemetry), which a store that batches (PostGIS:
        `upsert_deferred`) commits with others shortly after; otherwise committed first."""
        with self._write:
            batched = getattr(self.store, "upsert_deferred", None) if deferred else None
            change = batched(obj, replace_attributes=replace_attributes) if callable(batched) \
                else self.store.upsert(obj, replace_attributes=replace_attributes)
            for text in self.rules.apply(change, self.store):
                log.info("rule percept %s (on %s %r)", text, change.op, obj.id)
                if self._emit is not None:
                    self._emit(text)
        return change

    def upsert_many(self, objs: list[WorldObject], *, deferred: bool = False) -> list[Change]:
        """Store `objs` in order, in one transaction when the store can (SQLite), then
        run the rules on each change and emit what they produce. Returns once every
        write is committed; a failure raises (with SQLite nothing of the batch is kept).
        `deferred` (telemetry nobody waits for): a store that batches (PostGIS) queues
        them to be committed with others shortly after (`upsert_deferred`)."""
        with self._write:
            staged = getattr(self.store, "upsert_deferred", None) if deferred else None
            batch = getattr(self.store, "upsert_many", None)
            changes: list[Change] = [staged(obj) for obj in objs] if callable(staged) \
                else batch(objs) if callable(batch) else \
                [self.store.upsert(obj) for obj in objs]
            for change in changes:
                for text in self.rules.apply(change, self.store):
                    log.info("rule percept %s (on %s %r)", text, change.op, change.obj.id)
                    if self._emit is not None:
                        self._emit(text)
        return changes

    def seed(self, objects: Any, *, source: str = "seed") -> int:
        """Upsert a JSON list of objects; ConfigError naming the bad entry."""
        if not isinstance(objects, list):
            raise ConfigError("seed must be a JSON list of objects", file=source)
        for index, entry in enumerate(objects):
            try:
                self.upsert(WorldObject.from_json(entry))
            except ValueError as exc:
                raise ConfigError(f"object #{index}: {exc}", file=source) from None
        return len(objects)

    # --- bus functions -------------------------------------------------------------

    def call(self, function: str, args: list[Any], *, answer: bool = True) -> Any:
        """Run one bus function; ValueError/LookupError/TypeError for bad requests.

        Without `answer` (a request nobody waits for) a write returns only its `op`."""
        if function == "wm.get":
            (object_id,) = _arity(function, args, 1)
            obj = self.get(_string(object_id, "id"))
            return None if obj is None else obj.to_json()
        if function == "wm.list":
            kind = _arity(function, args, 0, 1)
            return [o.to_json() for o in self.objects(_opt_string(kind[0] if kind else None))]
        if function == "wm.upsert":
            (entry,) = _arity(function, args, 1)
            change = self.upsert(WorldObject.from_json(entry), deferred=not answer)
            if not answer:
                return {"op": change.op}
            return {"op": change.op, "object": change.obj.to_json()}
        if function == "wm.upsert_many":
            (entries,) = _arity(function, args, 1)
            if not isinstance(entries, list):
                raise TypeError("wm.upsert_many takes a list of objects")
            return self._upsert_many(entries, answer)
        if function == "wm.near":
            lat, lon, radius, *rest = _arity(function, args, 3, 4)
            found = self.near(Position(lat, lon), _number(radius, "radius_m"),
                                    _opt_string(rest[0] if rest else None))
            return [{**o.to_json(), "distance_m": d} for o, d in found]
        if function in ("wm.intersecting", "wm.within"):
            geometry, *rest = _arity(function, args, 1, 2)
            predicate = self.intersecting if function == "wm.intersecting" else self.within
            return [o.to_json() for o in predicate(
                Geometry.from_json(geometry), _opt_string(rest[0] if rest else None))]
        if function == "wm.within_distance":
            geometry, distance, *rest = _arity(function, args, 2, 3)
            found = self.within_distance(Geometry.from_json(geometry),
                                         _number(distance, "distance_m"),
                                         _opt_string(rest[0] if rest else None))
            return [{**o.to_json(), "distance_m": d} for o, d in found]
        if function == "wm.delete":
            (object_id,) = _arity(function, args, 1)
            return self.store.delete(_string(object_id, "id"))
        raise LookupError(f"unknown world model function {function!r}")

    def _upsert_many(self, entries: list[Any], answer: bool) -> list[dict[str, Any]]:
        """Per entry, in order: its result as `wm.upsert` gives it, or {"error": text}
        when the entry is not a valid object (the others are still written)."""
        results: list[dict[str, Any] | None] = []
        objs: list[WorldObject] = []
        for entry in entries:
            try:
                objs.append(WorldObject.from_json(entry))
                results.append(None)
            except (ValueError, LookupError, TypeError) as exc:
                results.append({"error": str(exc)})
        changes = iter(self.upsert_many(objs, deferred=not answer))
        for index, result in enumerate(results):
            if result is None:
                change = next(changes)
                results[index] = {"op": change.op, "object": change.obj.to_json()} \
                    if answer else {"op": change.op}
        return [r for r in results if r is not None]

    def handle(self, request: DataRequest) -> DataReply:
        """The reply to one bus request; errors become error replies."""
        self.requests += 1
        try:
            result = self.call(request.function, list(request.args),
                               answer=not request.request_id.startswith(NO_WAIT))
            return DataReply(request_id=request.request_id, ok=True, result=result)
        except (ValueError, LookupError, TypeError) as exc:
            self.request_errors += 1
            return DataReply(request_id=request.request_id, ok=False, error=str(exc))
        except WorldStoreUnavailable as exc:  # the database is down: no bug, no traceback
            self.request_errors += 1
            log.warning("world model request %s failed: %s", request.function, exc)
            return DataReply(request_id=request.request_id, ok=False,
                             error=f"{UNAVAILABLE_PREFIX}{exc}")
        except Exception as exc:
            self.request_errors += 1
            log.exception("world model request %s failed", request.function)
            return DataReply(request_id=request.request_id, ok=False,
                             error=f"{exc.__class__.__name__}: {exc}")


def _arity(function: str, args: list[Any], low: int, high: int | None = None) -> list[Any]:
    top = low if high is None else high
    if not low <= len(args) <= top:
        wanted = str(low) if top == low else f"{low} to {top}"
        raise TypeError(f"{function} takes {wanted} argument(s), got {len(args)}")
    return args


def _string(value: Any, name: str) -> str:
    if not isinstance(value, str):
        raise TypeError(f"{name} must be a string")
    return value


def _number(value: Any, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or value < 0:
        raise TypeError(f"{name} must be a non-negative number")
    return float(value)


def _opt_string(value: Any) -> str | None:
    return None if value is None else _string(value, "kind")


# --- configuration ----------------------------------------------------------------

BUILTIN_RULES = {"no_object_within"}


def builtin_rule(table: Mapping[str, Any], index: int) -> Rule:
    """A rule declared in project.toml (`[[worldmodel.rules]]`)."""
    key = f"worldmodel.rules[{index}]"
    kind = table.get("type")
    if kind != "no_object_within":
        raise ConfigError(f"unknown rule type {kind!r}; known: {sorted(BUILTIN_RULES)}",
                          key=key)
    try:
        return NoObjectWithin(kind=str(table["kind"]), other=str(table["other"]),
                              radius_m=float(table["radius_m"]),
                              functor=str(table.get("functor", f"{table['kind']}_detected")))
    except KeyError as exc:
        raise ConfigError(f"missing {exc.args[0]!r}", key=key) from None
    except (TypeError, ValueError) as exc:
        raise ConfigError(str(exc), key=key) from None


def load_rules(project_dir: Path | None, options: Mapping[str, Any]) -> list[Rule]:
    """The built-in rules of the config, then the project's `rules(options)` if any."""
    values = values_of(options)
    rules = [builtin_rule(t, i) for i, t in enumerate(values["rules"])]
    module_name = options.get("rules_module")
    if project_dir is None:
        return rules
    if module_name is None:
        if not project_file(project_dir, "worldmodel.py").is_file():
            return rules
        module_name = "worldmodel.py"
    module = import_project_module(project_dir, str(module_name), key="worldmodel.rules_module")
    factory = getattr(module, "rules", None)
    if not callable(factory):
        raise ConfigError("defines no function rules(options)", file=str(module.__file__))
    project_rules = list(factory(options))
    for each in project_rules:
        if not callable(getattr(each, "fire", None)):
            raise ConfigError(f"rules() returned {each!r}, which has no fire(change, world)",
                              file=str(module.__file__))
    return rules + project_rules


def load_seed(world: WorldModel, project_dir: Path | None, options: Mapping[str, Any]) -> int:
    """Load the `seed` file of the config into the world model; the number of objects."""
    seed = values_of(options)["seed"]
    if not seed or project_dir is None:
        return 0
    path = project_file(project_dir, str(seed), key="worldmodel.seed")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise ConfigError(f"cannot read: {exc.strerror}", file=str(path)) from None
    except ValueError as exc:
        raise ConfigError(f"not JSON: {exc}", file=str(path)) from None
    return world.seed(data, source=str(path))
