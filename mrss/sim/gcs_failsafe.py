"""The simulated copter's GCS failsafe, with ArduCopter's parameters and messages.

- FS_GCS_ENABLE: 0 disabled, 1 RTL, 3 SmartRTL-or-RTL, 4 SmartRTL-or-land, 5 land,
  6 DO_LAND_START-or-RTL, 7 brake-or-land (what the copter does: `CopterModel.gcs_failsafe`);
  other values are refused, as ArduPilot's parameter range does.
- FS_GCS_TIMEOUT: seconds (wall-clock) without a heartbeat from the GCS whose system id is
  SYSID_MYGCS (255, the ground station's usual id) before the failsafe fires.
- Fired: the copter says ``GCS Failsafe`` and acts; its HEARTBEAT reports
  MAV_STATE_CRITICAL while the failsafe is active. The GCS back: ``GCS Failsafe Cleared``,
  the state is no longer critical, and the mode stays what the failsafe chose.
- A GCS that was never heard never triggers it (`mrss.sim.controller_watch`).
"""

from __future__ import annotations

import logging

from mrss.links.ardupilot import FS_GCS_DISABLED, FS_GCS_ENABLE_OF, GCS_FAILSAFE_CLEARED_TEXT
from mrss.links.failsafe import DEFAULT_TIMEOUT_S, FailsafePolicy
from mrss.links.mavconn import MAV
from mrss.sim.controller_watch import ControllerWatch, WatchEvent
from mrss.sim.copter import FS_GCS_MODES, CopterModel

log = logging.getLogger("mrss.sim.uav")

GCS_SYSID = 255


class GcsFailsafe:
    """Watches the GCS heartbeats of one simulated copter and fires its failsafe."""

    def __init__(self, model: CopterModel, policy: FailsafePolicy | None = None) -> None:
        self.model = model
        self.enable = FS_GCS_ENABLE_OF[policy.action] if policy else FS_GCS_DISABLED
        self.watch = ControllerWatch(policy.timeout_s if policy else DEFAULT_TIMEOUT_S)
        self.gcs_sysid = GCS_SYSID
        self.fired = 0  # how many times the failsafe fired (for tests and logs)

    @property
    def active(self) -> bool:
        """Whether the failsafe is in force now (the GCS is lost)."""
        return self.watch.lost

    def set_enable(self, value: float) -> None:
        """Set FS_GCS_ENABLE; ValueError for a value ArduCopter does not have."""
        number = int(value)
        if number != value or (number != FS_GCS_DISABLED and number not in FS_GCS_MODES):
            raise ValueError(f"FS_GCS_ENABLE {value:g} is not a GCS failsafe action")
        self.enable = number
        if number == FS_GCS_DISABLED:
            self.watch.reset()

    def set_timeout(self, value: float) -> None:
        """Set FS_GCS_TIMEOUT in seconds; ValueError unless positive."""
        if not value > 0:
            raise ValueError("FS_GCS_TIMEOUT must be positive")
        self.watch.timeout_s = float(value)

    def heard(self, sysid: int, now: float) -> None:
        """A GCS heartbeat from system `sysid` arrived (wall-clock `now`)."""
        if sysid == self.gcs_sysid:
            self.watch.heard(now)

    def check(self, now: float) -> None:
        """Fire or clear the failsafe as the GCS's silence says (called every tick)."""
        if self.enable == FS_GCS_DISABLED:
            return
        event = self.watch.poll(now)
        if event is WatchEvent.LOST:
            self.fired += 1
            log.warning("GCS failsafe: no GCS heartbeat for %.1f s (FS_GCS_ENABLE %d)",
                        self.watch.timeout_s, self.enable)
            self.model.gcs_failsafe(self.enable)
        elif event is WatchEvent.REGAINED:
            log.info("GCS failsafe cleared: the GCS is back")
            self.model.texts.append((MAV.MAV_SEVERITY_WARNING, GCS_FAILSAFE_CLEARED_TEXT))
