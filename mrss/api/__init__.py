"""The whole contract for projects: every name a project's files import from MRSS.

A project's `rcl.py` subclasses `RobotCommLayer` (recipes: an action -> skills), its
`skills.py` subclasses `Skill`, its `datalayer.py` subclasses `DataLayer`, its
`events.py` subclasses `ExternalAdapter`. Test procedures also use `mrss.api.testing`.
Any other module of MRSS may change without notice; a test fails when a file under
projects/ imports one (docs/projects.md, "What a project may import").

By idea:
- actions and skills: Action, ActionState, FailureCause, Resource, Skill, SkillInterrupted,
  SkillOutcome, SkillState, RobotCommLayer, CriticalSection (what `Skill.critical`
  yields: a stretch of a skill no pre-emption, suspension or cancel cuts); plan_record
  (the dashboard map's `plan` robot data record, which `Skill.publish_plan` sends);
- tasks addressed to a role (docs/rcl.md, "Allocation"): Task (what it needs), Bid (what a
  robot offers), Evaluator (the named rankings); a project's own ranking is a method
  `RobotCommLayer.bid_score(task, bid)`;
- the edge (data layer, events adapter, world model): DataLayer, external, ExternalAdapter,
  Field, JsonMapping, PayloadError, Atom, Struct, literal, symbol, PredicateError, rule,
  NoObjectWithin, WorldModelClient, WorldModelRejected, WorldModelUnavailable,
  world_model_token, DependencyUnavailable; what a world model rule is given: WorldStore (the
  store and its spatial predicates), Geometry (a GeoJSON shape to ask about),
  WorldStoreUnavailable;
- robot links: RobotLink, create_link, connect_link, LINK_KINDS, LinkError, LinkDown,
  CommandRejected, CommandTimeout, publish_json, request_json;
- geography: distance_m, bearing_deg, offset, step_towards, EARTH_RADIUS_M; shortest_exit,
  Exit, NoExit (the shortest legal way out of a no-go zone, mrss.world.escape);
- errors: MrssError, ActionError, ConfigError, TransientError;
- options a project class declares for `mrss check`: Option, Check;
- a project's own component process (`module = "beacon:Beacon"` in project.toml):
  Component, ComponentContext;
- the project folder and its run folder: PROJECT_FILE, import_project_module,
  project_broker_url, simulator_address, BROKER_URL_FILE, WORLD_MODEL_URL_FILE.
"""

from __future__ import annotations

from mrss.actors.datalayer.layer import DataLayer, external
from mrss.actors.events.adapter import ExternalAdapter
from mrss.actors.rcl.action import Action
from mrss.actors.rcl.action import (
    check_json as check_json,  # the RCL's; not part of the contract
)
from mrss.actors.rcl.allocation.bids import Bid
from mrss.actors.rcl.allocation.evaluators import Evaluator
from mrss.actors.rcl.allocation.task import Task
from mrss.actors.rcl.layer import RobotCommLayer
from mrss.actors.rcl.lifecycle import (
    ACTION_TRANSITIONS as ACTION_TRANSITIONS,  # the RCL's; not part of the contract
)
from mrss.actors.rcl.skill import (
    SKILL_TRANSITIONS,
    CriticalSection,
    Resource,
    Skill,
    SkillInterrupted,
    SkillOutcome,
    SkillState,
)
from mrss.actors.worldmodel.rules import NoObjectWithin, rule
from mrss.actors.worldmodel.store import Geometry, WorldStore, WorldStoreUnavailable
from mrss.agentspeak.literals import Atom, PredicateError, Struct, literal, symbol
from mrss.config.broker import BROKER_URL_FILE
from mrss.config.projects import PROJECT_FILE
from mrss.edge.http_token import project_token as world_model_token
from mrss.edge.payloads import Field, JsonMapping, PayloadError
from mrss.edge.retry import DependencyUnavailable
from mrss.errors import ActionError, ConfigError, MrssError, TransientError
from mrss.links.base import RobotLink
from mrss.links.connect import connect_link, project_broker_url, simulator_address
from mrss.links.errors import CommandRejected, CommandTimeout, LinkDown, LinkError
from mrss.links.factory import LINK_OPTIONS, create_link
from mrss.links.geo import EARTH_RADIUS_M, bearing_deg, distance_m, offset, step_towards
from mrss.links.mqtt_publish import publish_json
from mrss.links.mqtt_request import request_json
from mrss.messages import ActionState, FailureCause
from mrss.messages.plans import plan_record
from mrss.options import Check, Option
from mrss.runtime.component import Component, ComponentContext
from mrss.runtime.loader import import_project_module
from mrss.world.access import (
    WORLD_MODEL_URL_FILE,
    WorldModelClient,
    WorldModelRejected,
    WorldModelUnavailable,
)
from mrss.world.escape import Exit, NoExit, shortest_exit

#: The robot link kinds a robot's `link` key may name.
LINK_KINDS: tuple[str, ...] = tuple(LINK_OPTIONS)

__all__ = [
    # actions and skills
    "Action", "ActionState", "CriticalSection", "FailureCause", "Resource", "RobotCommLayer",
    "SKILL_TRANSITIONS",
    "Skill", "SkillInterrupted", "SkillOutcome", "SkillState", "plan_record",
    # tasks addressed to a role
    "Bid", "Evaluator", "Task",
    # the edge
    "Atom", "DataLayer", "DependencyUnavailable", "ExternalAdapter", "Field", "JsonMapping",
    "NoObjectWithin", "PayloadError", "PredicateError", "Struct", "WorldModelClient",
    "WorldModelRejected", "WorldModelUnavailable", "external", "literal", "rule", "symbol",
    "world_model_token",
    "Geometry", "WorldStore", "WorldStoreUnavailable",
    # robot links
    "CommandRejected", "CommandTimeout", "LINK_KINDS", "LinkDown", "LinkError", "RobotLink",
    "connect_link", "create_link", "publish_json", "request_json",
    # geography
    "EARTH_RADIUS_M", "bearing_deg", "distance_m", "offset", "step_towards",
    "Exit", "NoExit", "shortest_exit",
    # errors
    "ActionError", "ConfigError", "MrssError", "TransientError",
    # the project folder and its run folder
    "BROKER_URL_FILE", "PROJECT_FILE", "WORLD_MODEL_URL_FILE", "import_project_module",
    "project_broker_url", "simulator_address",
    # options a project class reads from its table, declared for `mrss check`
    "Check", "Option",
    # a project's own component process
    "Component", "ComponentContext",
]
