"""Skills (paper IV-E, Table I "skills inheriting from Skill class").

ADAPT: one Skill subclass per robot capability. The RCL calls `start()`, then `run()`
on the skill's own thread (it may block on the robot's link, `self.link`), then
`finish(outcome)`. `run` returns True/None (succeeded) or False (failed, set
`self.reason`); an exception fails it too. On cancel/suspend the RCL sets
`self.interrupted` and calls `terminate()` from another thread: make `run` return
soon. `self.record_progress(k=v)` is kept across suspension and restarts and comes back
in `self.progress`, so a resumed action continues where it left off.
`self.publish_plan(waypoints, reached)` shows the path on the dashboard's map (send it
again as each waypoint is reached; the RCL clears it when the action ends).
"""

from __future__ import annotations

from mrss.api import Resource, Skill, SkillOutcome

MOTION = Resource("motion", per_robot=True)  # one moving action per robot at a time


class MoveTo(Skill):
    """Drive the robot to a point; succeeds on arrival."""

    resources = (MOTION,)

    def __init__(self, lat: float, lon: float) -> None:
        self.lat, self.lon = lat, lon

    def start(self) -> None:
        # ADAPT: with a real link (docs/robots.md), wait for it before the first command,
        # `self.link.wait_up(10.0)`: an action a restarted RCL resumes starts while the
        # new link still connects, and its command would fail at once (link_down).
        self.link.goto(self.lat, self.lon)
        self.publish_plan([[self.lat, self.lon]], 0)  # the dashboard's map: where it goes

    def run(self) -> bool:
        while not self.link.arrived():
            if self.wait(0.05):             # True when interrupted
                return False
            self.record_progress(travelled_m=round(self.link.travelled_m, 1))
        return True

    def finish(self, outcome: SkillOutcome) -> None:
        if outcome is SkillOutcome.INTERRUPTED:
            self.link.halt()                # stop the robot before another action takes it
