"""What the simulator and the MAVLink link agree on: ArduCopter modes, GCS failsafe, hotspots.

Hotspot reports travel as a STATUSTEXT (severity NOTICE) whose text is
``HOTSPOT <id> <lat> <lon> <temperature_c>``, e.g. ``HOTSPOT 3 -35.3630000 149.1650000 412``.
Any ground station shows it as a message; the link turns it into telemetry.

The GCS failsafe is ArduCopter's: parameters FS_GCS_ENABLE (the action) and
FS_GCS_TIMEOUT (seconds without a GCS heartbeat); the vehicle says ``GCS Failsafe``
(or ``GCS Failsafe - ...``) when it fires and ``GCS Failsafe Cleared`` when the GCS is
back, and reports MAV_STATE_CRITICAL in its HEARTBEAT while the failsafe is active.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from enum import StrEnum

from mrss.links.failsafe import FailsafeAction

COPTER_MODES: dict[str, int] = {
    "STABILIZE": 0,
    "ACRO": 1,
    "ALT_HOLD": 2,
    "AUTO": 3,
    "GUIDED": 4,
    "LOITER": 5,
    "RTL": 6,
    "CIRCLE": 7,
    "LAND": 9,
    "BRAKE": 17,
}
COPTER_MODE_NAMES: dict[int, str] = {number: name for name, number in COPTER_MODES.items()}

# FS_GCS_ENABLE values we set for each declared action: "always RTL", "always land",
# "brake or land" (ArduCopter 4.x numbering; 0 disables the GCS failsafe).
FS_GCS_ENABLE = "FS_GCS_ENABLE"
FS_GCS_TIMEOUT = "FS_GCS_TIMEOUT"
FS_GCS_DISABLED = 0
FS_GCS_ENABLE_OF: dict[FailsafeAction, int] = {
    FailsafeAction.RTL: 1,
    FailsafeAction.STOP: 5,
    FailsafeAction.HOLD: 7,
}
GCS_FAILSAFE_TEXT = "GCS Failsafe"
GCS_FAILSAFE_CLEARED_TEXT = "GCS Failsafe Cleared"


class GcsFailsafeEvent(StrEnum):
    """What a vehicle's GCS failsafe STATUSTEXT says happened."""

    ON = "on"
    CLEARED = "cleared"


def gcs_failsafe_event(text: str) -> GcsFailsafeEvent | None:
    """The GCS failsafe event a STATUSTEXT text reports, or None if it is another text."""
    text = text.strip("\x00").strip()
    if text == GCS_FAILSAFE_CLEARED_TEXT:
        return GcsFailsafeEvent.CLEARED
    if text.startswith((GCS_FAILSAFE_TEXT, "GCS + Battery Failsafe")):
        return GcsFailsafeEvent.ON
    return None


STATUSTEXT_MAX = 50
HOTSPOT_PREFIX = "HOTSPOT"
_HOTSPOT_RE = re.compile(
    r"^HOTSPOT (?P<id>\d{1,9}) (?P<lat>-?\d{1,2}\.\d+) (?P<lon>-?\d{1,3}\.\d+) "
    r"(?P<temp>-?\d{1,5}(?:\.\d+)?)$"
)


def mode_number(name: str) -> int:
    """The ArduCopter custom_mode number for a mode name (case-insensitive); KeyError if none."""
    return COPTER_MODES[name.upper()]


def mode_name(number: int) -> str:
    """The ArduCopter mode name for a custom_mode number, or ``MODE<n>`` if unknown."""
    return COPTER_MODE_NAMES.get(number, f"MODE{number}")


@dataclass(frozen=True)
class HotspotReport:
    """One hotspot seen by a UAV's thermal camera."""

    id: int
    lat: float
    lon: float
    temperature: float


def format_hotspot(report: HotspotReport) -> str:
    """The STATUSTEXT text carrying `report` (at most 50 characters)."""
    text = (f"{HOTSPOT_PREFIX} {report.id} {report.lat:.7f} {report.lon:.7f} "
            f"{report.temperature:.0f}")
    if len(text) > STATUSTEXT_MAX:
        raise ValueError(f"hotspot report too long for STATUSTEXT: {text!r}")
    return text


def parse_hotspot(text: str) -> HotspotReport | None:
    """The hotspot report in a STATUSTEXT text, or None if it is not a valid one."""
    match = _HOTSPOT_RE.match(text.strip("\x00").strip())
    if match is None:
        return None
    lat, lon = float(match["lat"]), float(match["lon"])
    if not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0):
        return None
    return HotspotReport(int(match["id"]), lat, lon, float(match["temp"]))
