"""What a running system answers the dashboard's polls with, for `mrss bench tui`.

`mrss tui` asks, by default, for a mind snapshot every second (`ctl.mind`), the root's
supervision tree every 2 s (`ctl.tree`) and the world model's objects every 2 s
(`wm.list` on `dl.request.wm`). `SystemSide` answers those in the feeder process with
snapshots made by the real code, of a system like the one the feeder's stream describes:

* mind: a real AgentSpeak `Agent` whose intentions wait on one action per running
  action of the stream (completed and started as the stream ends and starts them), with
  the robots' positions and batteries as percepts and a mission's beliefs (areas,
  goals), snapshotted as the reasoner does;
* tree: a `ChildStatus` tree of a supervised project (bus, world model, data layer,
  events, RCL, reasoner under the root), as `sup.tree`;
* world: `WorldObject`s as the world model lists them: the robots at their latest
  positions, bases, areas (polygons) and hotspots.
"""

from __future__ import annotations

import os
from collections.abc import Hashable
from typing import Any

from mrss.agentspeak.agent import Agent
from mrss.agentspeak.terms import Struct
from mrss.messages import (
    ActionStatus,
    Command,
    DataReply,
    DataRequest,
    Envelope,
    Message,
    MindSnapshot,
    RobotData,
    SupEvent,
    SupEventKind,
)
from mrss.supervision.status import ChildStatus
from mrss.world.objects import WorldObject

AGENT_NAME = "agent"
AREAS = 40  # mission areas (polygons) in the world model and as beliefs
HOTSPOTS = 20
COMPONENTS = ("bus", "worldmodel", "datalayer", "events", "rcl", "reasoner")
PROGRAM = """\
+!perform(R, G) : robot(R)
   <- +task(R, G, running);
      cover(R, G);
      -task(R, G, running).
+battery(R, B)[source(percept)] : B < 20 & not low(R) <- +low(R).
+battery(R, B)[source(percept)] : B >= 20 & low(R) <- -low(R).
"""


class _Host:
    """The agent's environment actions: each waits until the stream ends its action."""

    def execute(self, action: Struct, intention_id: int) -> Hashable:
        return str(action.args[1])  # the goal: the stream's action uuid

    def cancel(self, handle: Hashable) -> None:
        return None


def _initial_beliefs(robots: int) -> list[str]:
    beliefs = []
    for r in range(robots):
        beliefs += [f"robot(r{r})", f"{'isuav' if r % 2 else 'isugv'}(r{r})",
                    f"home(r{r}, base{r % 2})"]
    for a in range(AREAS):
        beliefs.append(f"area(a{a}, {47.0 + 0.001 * a:.4f}, {15.4 + 0.001 * a:.4f}, "
                       f"priority({a % 5}))")
    return beliefs


class SystemSide:
    """The answers to the dashboard's polls, kept in step with the stream it is sent."""

    def __init__(self, robots: int) -> None:
        self.robots = robots
        self.agent = Agent(PROGRAM, host=_Host(), name=AGENT_NAME,
                           beliefs=_initial_beliefs(robots), out=lambda line: None)
        self.agent.run_until_idle()
        self._started: list[tuple[str, str]] = []  # (robot, uuid) not yet given to the agent
        self._ended: list[str] = []
        self._running: set[str] = set()
        self._percepts: dict[tuple[str, str], str] = {}  # (robot, kind) -> literal perceived
        self._latest: dict[tuple[str, str], str] = {}
        self.positions: dict[str, tuple[float, float]] = {}
        self.answered = 0

    def observe(self, msg: Message) -> None:
        """A message the feeder publishes: the system's state moves on."""
        if isinstance(msg, ActionStatus):
            if msg.state == "running" and msg.uuid not in self._running:
                self._running.add(msg.uuid)
                self._started.append((msg.robot, msg.uuid))
            elif msg.state != "running" and msg.uuid in self._running:
                self._running.discard(msg.uuid)
                self._ended.append(msg.uuid)
        elif isinstance(msg, RobotData):
            data, robot = msg.data, msg.robot
            if data.get("type") == "position":
                self.positions[robot] = (float(data["lat"]), float(data["lon"]))
                self._latest[(robot, "position")] = \
                    f"position({robot}, {data['lat']:.6f}, {data['lon']:.6f})"
            elif data.get("type") == "battery":
                self._latest[(robot, "battery")] = \
                    f"battery({robot}, {float(data['remaining']):.0f})"

    def answer(self, env: Envelope) -> list[tuple[Message, str | None]]:
        """What the system sends back for `env` (with the topic, None: the message's)."""
        body = env.body
        if isinstance(body, Command) and body.command == "mind":
            self.answered += 1
            return [(self.mind(), None)]
        if isinstance(body, Command) and body.command == "tree":
            self.answered += 1
            return [(self.tree(), None)]
        if isinstance(body, DataRequest) and body.function == "wm.list":
            self.answered += 1
            return [(DataReply(request_id=body.request_id, ok=True, result=self.world()),
                     f"dl.reply.wm.{env.src}")]
        return []

    def mind(self) -> MindSnapshot:
        """The agent brought up to date with the stream, snapshotted as the reasoner does."""
        agent = self.agent
        for robot, uuid in self._started:
            agent.add_goal(f"perform({robot or 'r0'}, a{uuid})")
        self._started.clear()
        agent.run_until_idle()  # the new intentions now wait on their actions
        for uuid in self._ended:
            agent.complete_action(f"a{uuid}", True)
        self._ended.clear()
        for key, literal in self._latest.items():
            old = self._percepts.get(key)
            if old != literal:
                if old is not None:
                    agent.remove_percept(old)
                agent.add_percept(literal)
                self._percepts[key] = literal
        agent.run_until_idle()
        snap = agent.snapshot()
        return MindSnapshot(agent=AGENT_NAME, beliefs=[str(b) for b in snap["beliefs"]],
                            intentions=list(snap["intentions"]),
                            events=[_event_text(e) for e in snap["events"]])

    def tree(self) -> SupEvent:
        """The root supervisor's tree, as `ctl.tree` is answered."""
        children = tuple(ChildStatus(name, "worker", "running", pid=1000 + i, incarnation=1,
                                     uptime=60.0, budget=(0, 5, 10.0))
                         for i, name in enumerate(COMPONENTS))
        root = ChildStatus("bench", "supervisor", "running", pid=os.getpid(),
                           strategy="one_for_one", children=children)
        return SupEvent(event=SupEventKind.TREE, child="bench", supervisor="bench", pid=os.getpid(),
                        detail={"tree": root.to_dict()})

    def world(self) -> list[Any]:
        """Every object, as the world model's `wm.list` gives it."""
        objects = [{"id": robot, "kind": "robot", "position": {"lat": lat, "lon": lon},
                    "attributes": {"battery": 80.0}}
                   for robot, (lat, lon) in sorted(self.positions.items())]
        objects += [{"id": f"base{b}", "kind": "base",
                     "position": {"lat": 47.0 - 0.001 * b, "lon": 15.4}} for b in range(2)]
        for a in range(AREAS):
            lat, lon = 47.0 + 0.001 * a, 15.4 + 0.001 * a
            ring = [[lon, lat], [lon + 5e-4, lat], [lon + 5e-4, lat + 5e-4],
                    [lon, lat + 5e-4], [lon, lat]]
            objects.append({"id": f"a{a}", "kind": "area", "attributes": {"priority": a % 5},
                            "geometry": {"type": "Polygon", "coordinates": [ring]}})
        objects += [{"id": f"h{h}", "kind": "hotspot",
                     "position": {"lat": 47.0005 + 0.002 * h, "lon": 15.4003},
                     "attributes": {"confidence": 0.8}} for h in range(HOTSPOTS)]
        return [WorldObject.from_json(obj).to_json() for obj in objects]


def _event_text(event: Any) -> str:
    """A pending event as one line, as the reasoner shows it."""
    if not isinstance(event, dict):
        return str(event)
    owner = event.get("intention")
    return f"{event.get('trigger', '?')}" + (f"  (intention #{owner})" if owner is not None
                                            else "")
