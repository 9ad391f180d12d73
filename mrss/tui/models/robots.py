"""The robots as the TUI knows them: availability and link from `robot.<id>.state`,
latest telemetry from `robot.<id>.data`.

Telemetry comes in two shapes and both are understood: a link record with a `type`
(`{"type": "position", "lat": .., "lon": ..}`, `{"type": "battery", "remaining": ..}`,
`{"type": "tank", "level": .., "capacity": ..}`, see docs/robots.md), or one flat map
(`{"lat": .., "lon": .., "battery": 87, "tank": 12.5}`).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field
from typing import Any

from mrss.messages import FailureCause, RobotData, RobotState

HISTORY_SECONDS = 300.0  # the sparklines' span: the last five minutes
SERIES_POINTS = 600
STOPPED_LINK = "unknown"  # a robot's link once the system that reached it stopped
LONG_LIST = 4  # a longer list in the robot detail is shown as its length


@dataclass
class RobotView:
    """One robot: its last state message and its latest telemetry record of each type."""

    robot: str
    available: bool | None = None
    link: str = "?"
    reason: str = ""
    cause: str = ""  # why it is unavailable (a FailureCause value: "decommissioned", ...)
    teleop: bool | None = None
    records: dict[str, dict[str, Any]] = field(default_factory=dict)  # "" = flat records
    data_ts: float | None = None
    # battery %, altitude m, tank litres over the last HISTORY_SECONDS: (ts, value)
    series: dict[str, deque[tuple[float, float]]] = field(default_factory=dict)

    @property
    def decommissioned(self) -> bool:
        """Taken out of service by the operator (until recommissioned)."""
        return self.available is False and self.cause == FailureCause.DECOMMISSIONED

    def values(self) -> dict[str, float | None]:
        """The numbers the sparklines follow (None when the telemetry has none)."""
        tank = self._field("tank", "level")
        flat_tank = self.records.get("", {}).get("tank")
        if tank is None and isinstance(flat_tank, dict):
            tank = flat_tank.get("level")
        elif tank is None:
            tank = flat_tank
        alt = self._field("position", "relative_alt")
        if not _is_number(alt):
            alt = self._field("position", "alt")
        battery = self.records.get("battery", {}).get("remaining")
        if battery is None:
            flat = self.records.get("", {}).get("battery")
            battery = flat.get("remaining") if isinstance(flat, dict) else flat
        return {name: float(v) if v is not None and _is_number(v) else None
                for name, v in (("battery", battery), ("altitude", alt), ("tank", tank))}

    def record_series(self, ts: float) -> None:
        for name, value in self.values().items():
            if value is None:
                continue
            points = self.series.setdefault(name, deque(maxlen=SERIES_POINTS))
            if points and points[-1][0] == ts:
                points[-1] = (ts, value)
            else:
                points.append((ts, value))
            while points and ts - points[0][0] > HISTORY_SECONDS:
                points.popleft()

    def fields(self) -> list[tuple[str, Any]]:
        """Every telemetry field, `record.key` (flat ones by their key), sorted."""
        out: list[tuple[str, Any]] = []
        for record, data in sorted(self.records.items()):
            for key, value in sorted(data.items()):
                if key != "type":
                    if isinstance(value, list) and len(value) > LONG_LIST:
                        value = f"[{len(value)} items]"  # a plan's waypoints, a grid
                    out.append((f"{record}.{key}" if record else key, value))
        return out


    def _field(self, record: str, key: str) -> Any:
        value = self.records.get(record, {}).get(key)
        return value if value is not None else self.records.get("", {}).get(key)

    def place(self) -> tuple[float, float] | None:
        """(lat, lon) of its last position, None before the first."""
        lat, lon = self._field("position", "lat"), self._field("position", "lon")
        return (float(lat), float(lon)) if _is_number(lat) and _is_number(lon) else None

    def position(self) -> str:
        lat, lon = self._field("position", "lat"), self._field("position", "lon")
        if not _is_number(lat) or not _is_number(lon):
            return ""
        text = f"{lat:.5f}, {lon:.5f}"
        alt = self._field("position", "relative_alt")
        if not _is_number(alt):
            alt = self._field("position", "alt")
        return f"{text} alt {alt:.1f}" if _is_number(alt) else text

    def battery(self) -> str:
        value = self.records.get("battery", {}).get("remaining")
        if value is None:
            flat = self.records.get("", {}).get("battery")
            value = flat.get("remaining") if isinstance(flat, dict) else flat
        return f"{value:.0f}%" if _is_number(value) else ""

    def tank(self) -> str:
        tank: Any = self.records.get("tank")
        if tank is None:
            tank = self.records.get("", {}).get("tank")
        if isinstance(tank, dict):
            level, capacity = tank.get("level"), tank.get("capacity")
            if _is_number(level) and _is_number(capacity):
                return f"{level:.1f}/{capacity:.1f} L"
            tank = level
        return f"{tank:.1f} L" if _is_number(tank) else ""


class RobotsModel:
    """Robots by id, in the order first heard of."""

    def __init__(self) -> None:
        self.robots: dict[str, RobotView] = {}

    def _robot(self, robot: str) -> RobotView:
        view = self.robots.get(robot)
        if view is None:
            view = self.robots[robot] = RobotView(robot)
        return view

    def system_stopped(self) -> None:
        """The system stopped: nothing is known of any robot now (its last state and
        telemetry are kept for the detail screen, but not shown as current)."""
        for view in self.robots.values():
            view.available, view.link, view.teleop = None, STOPPED_LINK, None
            view.reason = "system stopped: not known"

    def apply_state(self, state: RobotState) -> None:
        view = self._robot(state.robot)
        view.available, view.link, view.reason = state.available, state.link, state.reason
        view.cause = state.cause.value
        teleop = state.attributes.get("teleop")
        if isinstance(teleop, bool):
            view.teleop = teleop

    def apply_data(self, data: RobotData, ts: float) -> None:
        view = self._robot(data.robot)
        kind = data.data.get("type")
        if isinstance(kind, str) and kind:
            view.records[kind] = dict(data.data)  # a link record: the latest of its type
        else:
            view.records.setdefault("", {}).update(data.data)  # flat: merge what is new
        view.data_ts = ts
        view.record_series(ts)


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)
