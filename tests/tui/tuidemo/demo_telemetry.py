"""A telemetry feed for tuidemo: each robot drives a circle, its battery and tank drain."""

from __future__ import annotations

import math
import threading

from mrss.messages import RobotData
from mrss.runtime.component import Component, ComponentContext


class Telemetry(Component):
    """Publishes `robot.<id>.data` records (position, battery, tank) every `period` s."""

    def __init__(self) -> None:
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def start(self, ctx: ComponentContext) -> None:
        robots = [str(r) for r in ctx.options.get("robots", [])]
        period = float(ctx.options.get("period", 0.5))
        self._thread = threading.Thread(target=self._feed, args=(ctx, robots, period),
                                        name="telemetry", daemon=True)
        self._thread.start()

    def _feed(self, ctx: ComponentContext, robots: list[str], period: float) -> None:
        step = 0
        while not self._stop.wait(period):
            step += 1
            for i, robot in enumerate(robots):
                angle = step / 20 + i
                ctx.publisher.publish(RobotData(robot=robot, data={
                    "type": "position", "lat": 47.07 + 0.001 * math.cos(angle),
                    "lon": 15.43 + 0.001 * math.sin(angle), "heading": None}))
                ctx.publisher.publish(RobotData(robot=robot, data={
                    "type": "battery", "remaining": max(0.0, 100.0 - step * 0.2 - i * 10),
                    "voltage": None, "current": None}))
                ctx.publisher.publish(RobotData(robot=robot, data={
                    "type": "tank", "level": max(0.0, 20.0 - step * 0.05), "capacity": 20.0,
                    "pumping": False}))

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5)
