"""Turn MAVLink telemetry messages into the link's plain telemetry records."""

from __future__ import annotations

from typing import Any


def telemetry_of(msg: Any) -> tuple[str, dict[str, Any]] | None:
    """(type, fields) of a telemetry record for `msg`, or None if it carries none we use."""
    kind = msg.get_type()
    if kind == "GLOBAL_POSITION_INT":
        return "position", {
            "lat": msg.lat * 1e-7, "lon": msg.lon * 1e-7,
            "alt": msg.alt / 1000.0, "relative_alt": msg.relative_alt / 1000.0,
            "vx": msg.vx / 100.0, "vy": msg.vy / 100.0, "vz": msg.vz / 100.0,
            "heading": None if msg.hdg == 0xFFFF else msg.hdg / 100.0,
        }
    if kind == "SYS_STATUS":
        return "battery", {
            "voltage": None if msg.voltage_battery == 0xFFFF else msg.voltage_battery / 1000.0,
            "current": None if msg.current_battery == -1 else msg.current_battery / 100.0,
            "remaining": None if msg.battery_remaining == -1 else float(msg.battery_remaining),
        }
    if kind == "MISSION_CURRENT":
        return "mission", {"current": msg.seq, "total": msg.total, "reached": None}
    if kind == "MISSION_ITEM_REACHED":
        return "mission", {"current": None, "total": None, "reached": msg.seq}
    return None
