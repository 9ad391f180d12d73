"""A link keeps the robot's place and battery as records arrive (what allocation bids
from, read without a lock): each kind replaces its own half; a refused record, or one
without the figure, does not leave a stale one behind."""

from __future__ import annotations

from mrss.actors.rcl.allocation.bids import link_state
from mrss.links.base import RobotLink


class Link(RobotLink):
    def start(self) -> None:
        pass

    def close(self) -> None:
        self._mark_closed()


def test_whereabouts_follow_the_position_and_battery_records() -> None:
    link = Link("uav1")
    assert link.whereabouts() == (None, None)
    link._publish_telemetry("position", {"lat": 48.2, "lon": 16.3, "alt": 10.0})
    assert link.whereabouts() == ((48.2, 16.3), None)
    link._publish_telemetry("battery", {"remaining": 71, "voltage": 12.1})
    link._publish_telemetry("status", {"mode": "GUIDED"})  # neither: unchanged
    assert link.whereabouts() == ((48.2, 16.3), 71.0)
    assert link_state(link) == ((48.2, 16.3), 71.0)  # what the RCL's bids read
    link._publish_telemetry("position", {"lat": 95.0, "lon": 16.3})  # refused: kept
    assert link.whereabouts() == ((48.2, 16.3), 71.0)
    link._publish_telemetry("battery", {"voltage": 11.9})  # no remaining: unknown now
    assert link.whereabouts() == ((48.2, 16.3), None)
    position = link.latest("position")  # the records themselves are as they were
    assert position is not None and (position["lat"], position["alt"]) == (48.2, 10.0)


def test_a_link_says_its_robot_is_teleoperated_while_its_last_status_says_so() -> None:
    link = Link("ugv1")
    assert link.reports_teleop() is False
    link._publish_telemetry("status", {"mode": "teleop", "teleop": True})
    assert link.reports_teleop() is True
    link._publish_telemetry("battery", {"remaining": 50})  # another kind: unchanged
    assert link.reports_teleop() is True
    link._publish_telemetry("status", {"mode": "idle", "teleop": False})
    assert link.reports_teleop() is False
    link._publish_telemetry("status", {"mode": "idle", "teleop": "yes"})  # not true
    assert link.reports_teleop() is False
