"""The Symbol and Data Layer component (paper IV-C): grounding, external functions, telemetry.

It runs the project's `DataLayer` (from `projects/<name>/datalayer.py`, or the default
one that grounds ids from the world model). `DataRequest`s arrive on `dl.request`; each
gets exactly one `DataReply` on `dl.reply` with the same `request_id`: the result, or
`ok=False` with the error text when the function is unknown, raises, returns something
that is not plain data, or runs longer than `call_timeout`. Robot telemetry
(`RobotData` on `robot.<id>.data`) goes to `DataLayer.on_telemetry`, in order. The
project's percepts go on the reliable channel "percept", with a copy on the `percept`
topic (`mrss.runtime.percept_channel`).

project.toml:
    [datalayer]
    module = "datalayer.py"     # default; the default DataLayer when the file is absent
    class = "Name"              # when the file defines several
    call_timeout = 5.0          # seconds before a call is answered with an error
    workers = 4                 # calls running at once
    world_model = "bus"         # "bus" (embedded component), "http://host:port", or "none"
    robots = ["uav1", "ugv1"]   # who may send robot data (default: the RCL's robots table)
    alt_range = [-500, 12000]   # physical limits over the robot type's (record_declarations)
    geofence = true             # a robot stopped inside a no-go zone is given its way out
The `[components.<id>]` free keys of this component are laid over `[datalayer]`.

Robot data is checked before the project sees it (`mrss.edge.validation`): a record from
a robot that is not configured, or outside its declaration and limits, is refused —
counted (`DataLayerService.rejections`), logged once per (robot, reason) and interval
with a summary, and never handed to `on_telemetry` (so no world model write, no percept).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Mapping
from concurrent.futures import ThreadPoolExecutor
from concurrent.futures import TimeoutError as FutureTimeout
from pathlib import Path
from typing import Any, ClassVar

from mrss.actors.datalayer.geofence import Geofence
from mrss.actors.datalayer.layer import DataLayer, DataLayerContext
from mrss.actors.datalayer.telemetry_queue import TelemetryQueue
from mrss.actors.datalayer.told_percepts import ToldPercepts
from mrss.config.broker import table
from mrss.config.loader import load_file
from mrss.config.projects import PROJECT_FILE
from mrss.edge.http_token import configured_token
from mrss.edge.record_declarations import (
    DEFAULT_LIMITS,
    LIMIT_NAMES,
    RobotType,
    configured_robots,
)
from mrss.edge.rejections import RejectionLog
from mrss.edge.retry import DependencyUnavailable
from mrss.edge.robot_owners import RobotOwners
from mrss.edge.validation import RecordValidator, Rejected, limit_overrides
from mrss.errors import ConfigError, TransientError
from mrss.messages import DataReply, DataRequest, Envelope, Percept, RobotData, Topic
from mrss.options import Check, Option, OptionValues
from mrss.runtime.busport import BusPort, bus_port
from mrss.runtime.component import Component, ComponentContext
from mrss.runtime.datalayer_client import DataLayerClient, DataLayerError
from mrss.runtime.edge import edge_config
from mrss.runtime.loader import load_project_class, project_file
from mrss.runtime.percept_channel import PerceptChannel
from mrss.runtime.percepts import PerceptPublisher, PerceptSink
from mrss.world.access import BusWorldModel, HttpWorldModel, WorldModelAccess

__all__ = ["DataLayerClient", "DataLayerComponent", "DataLayerError", "DataLayerService",
           "TelemetryQueue"]
DEFAULT_MODULE = "datalayer.py"
log = logging.getLogger("mrss.datalayer")


def plain(value: Any, depth: int = 0) -> Any:
    """`value` as bus-safe plain data (tuples become lists); TypeError otherwise."""
    if depth > 64:
        raise TypeError("result is nested too deeply")
    if value is None or isinstance(value, (bool, int, str, bytes)):
        return value
    if isinstance(value, float):
        if not math.isfinite(value):
            raise TypeError("result holds a non-finite number")
        return value
    if isinstance(value, (list, tuple)):
        return [plain(v, depth + 1) for v in value]
    if isinstance(value, dict) and all(isinstance(k, str) for k in value):
        return {k: plain(v, depth + 1) for k, v in value.items()}
    raise TypeError(f"result holds a {type(value).__name__}, which is not plain data")


class DataLayerService:
    """Runs calls on a worker pool with a time limit; every request gets one reply."""

    def __init__(self, datalayer: DataLayer, *, call_timeout: float = 5.0,
                 workers: int = 4, validator: RecordValidator | None = None,
                 reject_interval: float = 60.0, geofence: Geofence | None = None) -> None:
        self.datalayer = datalayer
        self.geofence = geofence
        self.validator = validator or RecordValidator()
        self.rejections = RejectionLog(log, "robot data", interval=reject_interval)
        self.call_timeout = call_timeout
        self.functions = datalayer.functions()
        self._pool = ThreadPoolExecutor(max_workers=workers, thread_name_prefix="dl-call")
        self.requests = 0
        self.errors = 0
        self.timeouts = 0
        self.telemetry_errors = 0
        self.telemetry_down = False   # the last record failed on a dependency

    def handle(self, request: DataRequest) -> DataReply:
        """Run one request; the reply carries the result or the error text."""
        self.requests += 1
        function = self.functions.get(request.function)
        if function is None:
            return self._error(request, f"unknown function {request.function!r}; known: "
                               f"{', '.join(sorted(self.functions))}")
        future = self._pool.submit(function, *request.args)
        try:
            result = plain(future.result(timeout=self.call_timeout))
        except FutureTimeout:
            self.timeouts += 1
            return self._error(request, f"{request.function} timed out after "
                               f"{self.call_timeout:g}s", transient=True)
        except Exception as exc:
            if not isinstance(exc, (LookupError, TypeError, ValueError, DataLayerError)):
                log.warning("data layer function %s failed: %r", request.function, exc)
            return self._error(request, f"{request.function}: {exc.__class__.__name__}: {exc}",
                               transient=isinstance(exc, TransientError))
        return DataReply(request_id=request.request_id, ok=True, result=result)

    def telemetry(self, data: RobotData) -> bool:
        """Hand telemetry to the project once it passed validation; a refusal or a
        failure is logged and counted."""
        try:
            record = self.validator.check(data.robot, data.data)
        except Rejected as exc:
            self.rejections.reject(str(data.robot), exc.reason, exc.detail)
            return False
        try:
            self.datalayer.on_telemetry(data.robot, record)
        except DependencyUnavailable as exc:   # the world model (or its database) is down
            self.telemetry_errors += 1
            if not self.telemetry_down:
                log.warning("telemetry not stored while a dependency is down (%s); the "
                            "next records are tried as they come", exc)
            self.telemetry_down = True
            return False
        except Exception:
            self.telemetry_errors += 1
            log.exception("telemetry of robot %s could not be forwarded", data.robot)
            return False
        if self.telemetry_down:
            self.telemetry_down = False
            log.warning("telemetry stored again")
        if self.geofence is not None:
            self.geofence.observe(data.robot, record)
        return True

    def _error(self, request: DataRequest, text: str, transient: bool = False) -> DataReply:
        """An error reply; `transient`: the function's own dependency was away (the
        world model did not answer) or it ran out of time, so the caller may retry."""
        self.errors += 1
        return DataReply(request_id=request.request_id, ok=False, error=text,
                         transient=transient)

    def close(self) -> None:
        """Stop the workers (calls still running are abandoned)."""
        self._pool.shutdown(wait=False, cancel_futures=True)


def world_access(section: Mapping[str, Any], bus: BusPort | None, *,
                 token: str | None = None) -> WorldModelAccess | None:
    """The world model the `[datalayer] world_model` option points to (over HTTP with
    the project's world model `token`)."""
    target = OptionValues(DataLayerComponent.OPTIONS, section, section="datalayer").raw(
        "world_model")  # judged below: 'bus', 'none' or a URL
    if target == "none":
        return None
    if target == "bus":
        if bus is None:
            raise ConfigError("world_model = 'bus' needs the bus", key="datalayer.world_model")
        return BusWorldModel(bus)
    if isinstance(target, str) and target.startswith(("http://", "https://")):
        return HttpWorldModel(target, token=token)
    raise ConfigError(f"{target!r}: use 'bus', 'none' or an http:// URL",
                      key="datalayer.world_model")


def load_datalayer_class(project_dir: Path, section: Mapping[str, Any]) -> type[DataLayer]:
    """The project's DataLayer subclass, or the default when there is no datalayer.py."""
    module = section.get("module")
    if module is None and not project_file(project_dir, DEFAULT_MODULE).is_file():
        return DataLayer
    return load_project_class(project_dir, str(module or DEFAULT_MODULE), DataLayer,
                              class_name=section.get("class"), key="datalayer.module")


def robot_validator(project_dir: Path, section: Mapping[str, Any]) -> RecordValidator:
    """The check of robot data for a project: its robots (`robots`, else the RCL's robots
    table) and their limits (the robot type's, with the `*_range` options over them)."""
    components: dict[str, Any] = {}
    if (project_dir / PROJECT_FILE).is_file():
        components = {c.id: c.options for c in load_file(project_dir / PROJECT_FILE).components}
    types = configured_robots({"components": components})
    listed = section.get("robots")
    if listed is not None:
        if not isinstance(listed, list) or not all(isinstance(r, str) for r in listed):
            raise ConfigError("must be a list of robot ids", key="datalayer.robots")
        types = {r: types.get(r, RobotType.GROUND) for r in listed}
    try:
        overrides = limit_overrides(section)
    except Rejected as exc:
        raise ConfigError(exc.detail, key=f"datalayer.{exc.reason}") from None
    if not types:
        log.info("robot ids of robot data are not checked: no robot is configured")
    limits = {robot: DEFAULT_LIMITS[kind].overridden(overrides) for robot, kind in types.items()}
    return RecordValidator(types or None, limits=limits,
                           default=DEFAULT_LIMITS[RobotType.GROUND].overridden(overrides))


class DataLayerComponent(Component):
    """Component: serves `dl.request` and forwards `robot.*.data` telemetry."""

    #: The options this component reads (`mrss check` validates them; docs/config.md).
    SECTION: ClassVar[str] = "datalayer"  # read from [datalayer], under its own table's keys
    OPTIONS: ClassVar[tuple[Option, ...]] = (
        Option("module", str, "datalayer.py", "the project's DataLayer file", Check.PROJECT_FILE),
        Option("class", str, None, "the DataLayer subclass, when the file has several"),
        Option("call_timeout", float, 5.0, "seconds before a call is answered with an error",
               Check.POSITIVE),
        Option("workers", int, 4, "calls running at once", Check.POSITIVE),
        Option("world_model", str, "bus", "\"bus\", \"none\" or the world model's http:// URL"),
        Option("world_model_timeout", float, 2.0, "seconds per world model call", Check.POSITIVE),
        Option("robots", list, None, "robot ids whose data is taken (default: the RCL's "
               "robots table; unchecked when no robot is configured anywhere)"),
        Option("reject_log_interval", float, 60.0, "seconds between summaries of refused "
               "robot data", Check.POSITIVE),
        *(Option(f"{name}_range", list, None, f"[low, high] of {name.replace('_', ' ')} "
                 "over the robot type's default (mrss.edge.record_declarations)", Check.RANGE)
          for name in LIMIT_NAMES),
        *Geofence.OPTIONS,
    )

    def __init__(self) -> None:
        self.datalayer: DataLayer | None = None
        self.service: DataLayerService | None = None
        self._bus: BusPort | None = None
        self._dispatch: ThreadPoolExecutor | None = None
        self._telemetry: TelemetryQueue | None = None
        self._world: WorldModelAccess | None = None
        self._percepts: PerceptChannel | None = None
        self._owners = RobotOwners({})
        self._told: ToldPercepts | None = None

    def start(self, ctx: ComponentContext) -> None:
        """Component entry: bus and percept channel from the context, then `run`."""
        bus = bus_port(ctx)
        self._percepts = PerceptChannel.for_component(ctx)
        config = edge_config(ctx, "datalayer")
        if Geofence.on(table(config, "datalayer")):
            # what the geofence told outlives this incarnation, not the run
            self._told = ToldPercepts(ctx.run_dir / f"{ctx.name}-geofence.sqlite3",
                                      fresh=ctx.incarnation <= 1)
        channel = self._percepts
        self.run(ctx.project_dir, config, bus, percepts=channel.send,
                 proven=bool(ctx.bus.get("key")), told=self._told,
                 settled=lambda: channel.pending() == 0)
        bus.wait_connected(5.0)  # ready means requests are heard

    def run(self, project_dir: Path, config: Mapping[str, Any], bus: BusPort, *,
            percepts: PerceptSink | None = None, proven: bool = False,
            told: ToldPercepts | None = None,
            settled: Callable[[], bool] = lambda: True) -> None:
        """Load the project's data layer and serve requests on `bus`.

        The project's percepts go to `percepts` (default: published on `bus`); `proven`:
        the bus has the run's incarnation key (robot data needs a proven incarnation);
        `told`: where the geofence keeps what it told (default: in memory), `settled`:
        whether every percept sent is acknowledged.
        """
        section = table(config, "datalayer")
        values = OptionValues(self.OPTIONS, section, section="datalayer")
        cls = load_datalayer_class(project_dir, section)
        timeout, workers = values.number("call_timeout"), values.whole("workers")
        self._bus = bus
        over_http = values.text("world_model").startswith(("http://", "https://"))
        token = configured_token(table(config, "worldmodel"), project_dir) if over_http \
            else None
        self._world = world_access(section, bus, token=token)

        def to_bus(percept: Percept, _msg_id: str | None) -> None:
            bus.publish(percept)

        options = {k: v for k, v in section.items() if k not in ("module", "class")}
        publisher = PerceptPublisher(percepts or to_bus)
        self.datalayer = cls(DataLayerContext(world=self._world, percept=publisher,
                                              options=options, project_dir=project_dir,
                                              log=log))
        self.datalayer.start()
        self.service = DataLayerService(
            self.datalayer, call_timeout=timeout, workers=workers,
            validator=robot_validator(project_dir, section),
            reject_interval=values.number("reject_log_interval"),
            geofence=Geofence.configured(section, self._world, publisher, told=told,
                                         settled=settled))
        # Dispatch threads wait on calls, so a slow call never holds up the others.
        self._dispatch = ThreadPoolExecutor(max_workers=workers * 2,
                                            thread_name_prefix="dl-dispatch")
        self._telemetry = TelemetryQueue(self.service.telemetry)
        # Robot data is taken only from the component that owns the robot's link.
        self._owners = RobotOwners.of_project(project_dir, proven=proven)
        bus.subscribe([Topic.DL_REQUEST.value, Topic.ROBOT.value], self._on_message)
        log.info("data layer %s serving %d functions", cls.__name__,
                 len(self.service.functions))

    def _on_message(self, env: Envelope) -> None:
        body = env.body
        if isinstance(body, DataRequest) and env.topic == Topic.DL_REQUEST.value:
            assert self._dispatch is not None
            self._dispatch.submit(self._answer, body)
        elif isinstance(body, RobotData) and self._owners.admits(env):
            assert self._telemetry is not None and self.service is not None
            self._telemetry.put(body)

    def _answer(self, request: DataRequest) -> None:
        assert self.service is not None and self._bus is not None
        try:
            reply = self.service.handle(request)
        except Exception as exc:  # never leave a caller waiting for a reply that won't come
            log.exception("data layer request %s failed", request.function)
            reply = DataReply(request_id=request.request_id, ok=False,
                              error=f"internal error: {exc.__class__.__name__}")
        self._bus.publish(reply)

    def stats(self) -> dict[str, object]:
        """Counters for logs and dashboards: calls, errors, refused robot data."""
        svc = self.service
        if svc is None:
            return {}
        return {"requests": svc.requests, "errors": svc.errors, "timeouts": svc.timeouts,
                "telemetry_errors": svc.telemetry_errors,
                "rejected": svc.rejections.total, "rejected_by": svc.rejections.stats()}

    def stop(self) -> None:
        """Stop serving, then stop the project's data layer."""
        if self._bus is not None:
            self._bus.close()
        if self._dispatch is not None:
            self._dispatch.shutdown(wait=False, cancel_futures=True)
        if self._telemetry is not None:
            self._telemetry.close()
        try:
            if self.datalayer is not None:
                self.datalayer.stop()
        finally:
            if self.service is not None:
                self.service.rejections.flush()
                self.service.close()
            if self._percepts is not None:
                self._percepts.flush(1.0)
                self._percepts.close()
            if self._told is not None:
                self._told.close()
