"""Operator requests of the AMADEE-24 rover: MQTT JSON -> percepts.

Topics (prefix `[events] topic_prefix`, default "mrss/ui"):

    <prefix>/drive    {"goal": "g1", "lat": 39.7705, "lon": 44.8}  -> drive_received(g1, Lat, Lon)
    <prefix>/science  {"goal": "g2", "what": "image"}              -> science_received(g2, image)
                      (what: image | spectrum | radar | sample, where the rover stands)
    <prefix>/home     {"goal": "g3"}                               -> home_received(g3)
    <prefix>/cancel   {"goal": "g1"}                               -> goal_cancelled(g1)
    <prefix>/crew     {"id": "eva1", "lat": 39.77, "lon": 44.798, "on_eva": true}
                      a crew member's position telemetry (from the suit): the world model
                      object `eva1`, of kind `crew` while on EVA (the crew_safety rule
                      keeps the rover away from it), `crew_inside` once back

Every message is answered on `<topic>/reply` (accepted, or rejected with the reason).
Whether the action is legal is decided later by the reasoner: its verdict is the world
model object `verdict_<goal>`, and is published once on `<prefix>/verdict`
(verdict_watch.py): `{"goal", "legal", "rule", "detail", "action"}`.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from mrss.api import Atom, ExternalAdapter, Field, JsonMapping, Option, import_project_module

verdict_watch = import_project_module(Path(__file__).resolve().parent, "verdict_watch.py")

GOAL = Field("goal", "atom")
DRIVE = JsonMapping("drive_received", GOAL, Field("lat", "lat"), Field("lon", "lon"))
HOME = JsonMapping("home_received", GOAL)
CANCEL = JsonMapping("goal_cancelled", GOAL)
SCIENCE_KINDS = ("image", "spectrum", "radar", "sample")
CREW = (Field("id", "atom"), Field("lat", "lat"), Field("lon", "lon"),
        Field("on_eva", "bool", True))
CREW_KINDS = ("crew", "crew_inside")


class AmadeeEvents(ExternalAdapter):
    """The mission support's requests, seen through MQTT."""

    OPTIONS = (Option("topic_prefix", str, "mrss/ui", "prefix of the operator's topics"),)

    def start(self) -> None:
        prefix = str(self.options.get("topic_prefix", "mrss/ui")).rstrip("/")
        world = self.world_model()
        self.verdicts = verdict_watch.VerdictWatch(
            world.get, lambda text: self.mqtt.publish(f"{prefix}/verdict", text), log=self.log)
        self.verdicts.start()
        self.on_json(f"{prefix}/drive", self.on_request(DRIVE))
        self.on_json(f"{prefix}/home", self.on_request(HOME))
        self.map_json(f"{prefix}/cancel", CANCEL)
        self.on_json(f"{prefix}/science", self.on_science)
        self.on_json(f"{prefix}/crew", self.on_crew)

    def stop(self) -> None:
        self.verdicts.stop()

    def on_request(self, mapping: JsonMapping) -> Callable[[str, dict[str, Any]], None]:
        """A handler: the request's percept, its verdict awaited for the operator."""
        def handle(topic: str, obj: dict[str, Any]) -> None:
            args = mapping.args(obj, topic=topic)
            self.verdicts.expect(str(args[0]))
            self.percept(mapping.functor, *args)
        return handle

    def on_science(self, topic: str, obj: dict[str, Any]) -> None:
        goal = GOAL.extract(obj)
        what = obj.get("what")
        if what not in SCIENCE_KINDS:
            raise ValueError(f"what must be one of {', '.join(SCIENCE_KINDS)}, not {what!r}")
        self.verdicts.expect(str(goal))
        self.percept("science_received", goal, Atom(str(what)))

    def on_crew(self, topic: str, obj: dict[str, Any]) -> None:
        """A crew member's position into the world model (no percept: the rules read it)."""
        crew, lat, lon, on_eva = (f.extract(obj) for f in CREW)
        world = self.world_model()
        known = world.get(str(crew))
        if known is not None and known.get("kind") not in CREW_KINDS:
            raise ValueError(f"id {str(crew)!r} is a {known.get('kind')} in the world model, "
                             "not a crew member")
        world.upsert({"id": str(crew), "kind": CREW_KINDS[0] if on_eva else CREW_KINDS[1],
                      "position": {"lat": lat, "lon": lon},
                      "attributes": {"on_eva": bool(on_eva)}})
