"""External adapter (paper IV-B, Table I "Event External Adapter"): outside events -> percepts.

ADAPT: subscribe to what your user interface or sensors publish and turn each message
into percepts for agent.asl. The events manager gives the adapter:
- `self.mqtt`: a client of the project's broker (`[broker] url`, or the embedded one);
- `self.percept(functor, *args)` / `self.percept("literal(text)")`: publish a percept,
  `op="remove"` to retract one; arguments are quoted safely (`Atom("a1")` for atoms);
- `self.map_json(topic, JsonMapping(...))`: a declared payload schema -> one percept;
- `self.on_json(topic, handler)`: your own handler for JSON objects;
- `self.options`: the `[events]` table of project.toml;
- `self.world_model()`: the run's world model, found again for every call (restarts).
A payload that does not fit is counted and reported back on `<topic>/reply`, never a
percept. A handler whose dependency is down raises `DependencyUnavailable` (the world
model client does): the message is retried, then reported `failed` on `<topic>/reply`
and the dashboard. A payload's `"id"` makes a repeat of it one event.
"""

from __future__ import annotations

from mrss.api import ExternalAdapter, Field, JsonMapping, Option

# ADAPT: one schema per message kind. `{"goal": "g1", "lat": 48.2, "lon": 16.37}`
GOTO = JsonMapping("goto_received", Field("goal", "atom"), Field("lat", "lat"),
                   Field("lon", "lon"))
CANCEL = JsonMapping("goal_cancelled", Field("goal", "atom"))
# `{"goal": "i1", "lat": 48.2, "lon": 16.37}`: a goal for any robot that can (a role)
INSPECT = JsonMapping("inspect_received",
                      Field("goal", "atom"),
                      Field("lat", "lat"),
                      Field("lon", "lon"))


class ProjectEvents(ExternalAdapter):
    """ADAPT: the project's external adapter (exactly one ExternalAdapter subclass here)."""

    #: ADAPT: every key of [events] this adapter reads (`mrss check` rejects the others).
    OPTIONS = (Option("topic_prefix", str, "mrss/ui", "prefix of the UI's topics"),)

    def start(self) -> None:
        prefix = str(self.options.get("topic_prefix", "mrss/ui")).rstrip("/")
        self.map_json(f"{prefix}/goto", GOTO)
        self.map_json(f"{prefix}/cancel", CANCEL)
        self.map_json(f"{prefix}/inspect", INSPECT)
