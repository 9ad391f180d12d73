"""A robot for tuimap: it drives east along a line, reporting its position and heading,
and its plan (four waypoints along the line, `mrss.messages.plans`) as each waypoint is passed."""

from __future__ import annotations

import threading

from mrss.messages import RobotData
from mrss.messages.plans import plan_record
from mrss.runtime.component import Component, ComponentContext

WAYPOINT_STEPS = (0, 33, 66, 99)  # steps of the drive at the plan's waypoints


class Drive(Component):
    """Publishes `robot.<id>.data` position records every `period` s, moving east."""

    def __init__(self) -> None:
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def start(self, ctx: ComponentContext) -> None:
        robot = str(ctx.options.get("robot", "ugv1"))
        period = float(ctx.options.get("period", 0.3))
        self._thread = threading.Thread(target=self._feed, args=(ctx, robot, period),
                                        name="drive", daemon=True)
        self._thread.start()

    def _feed(self, ctx: ComponentContext, robot: str, period: float) -> None:
        step, reached = 0, -1
        waypoints = [[47.070, 15.428 + 0.00015 * s] for s in WAYPOINT_STEPS]
        while not self._stop.wait(period):
            step = (step + 1) % 100
            ctx.publisher.publish(RobotData(robot=robot, data={
                "type": "position", "lat": 47.070, "lon": 15.428 + 0.00015 * step,
                "heading": 90.0}))
            passed = sum(1 for s in WAYPOINT_STEPS if s <= step)
            # not at telemetry rate: when a waypoint is passed, and every 5th record for
            # a dashboard that attached since
            if passed != reached or step % 5 == 0:
                reached = passed
                ctx.publisher.publish(RobotData(robot=robot, data=plan_record(
                    "drive", waypoints, passed, "line")))

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5)
