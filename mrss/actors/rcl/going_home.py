"""Sending a robot home for a stand-down (mode home), once its skills have stopped.

The stand-down suspends the robot's actions first (mrss.actors.rcl.stand_down); each
skill's `terminate` stops the robot, asynchronously. A "go home" sent before that stop
could be overtaken by it (a copter told RTL, then BRAKE), so the robot actor is told
`GoHome` after the suspensions and sends it only once none of its skills runs: the
errand waits in `HomeErrand` until then. The link's `go_home` (MAVLink: RTL; the MQTT
ground robot: `return_to_base`) runs on a thread of its own, so a link that waits for
an acknowledgement never blocks the actor; a link without one logs why the robot stays
where it is (held).
"""

from __future__ import annotations

import logging
import threading
from dataclasses import dataclass
from typing import Any

log = logging.getLogger("mrss.rcl.stand_down")


@dataclass(frozen=True)
class GoHome:
    """To a robot actor: send the robot home once its skills have stopped."""

    ident: str  # the stand-down's


class HomeErrand:
    """One robot's pending "go home", sent when its skills have stopped."""

    def __init__(self, robot: str, link: Any) -> None:
        self.robot, self.link = robot, link
        self.pending: str = ""  # the stand-down asking, until sent

    def ask(self, message: GoHome) -> None:
        self.pending = message.ident

    def check(self, skills_running: bool) -> None:
        """Send it now if one is pending and no skill runs."""
        if not self.pending or skills_running:
            return
        ident, self.pending = self.pending, ""
        go_home = getattr(self.link, "go_home", None)
        if not callable(go_home):
            log.warning("stand-down %s: %s's link cannot send it home: it holds where it is",
                        ident, self.robot)
            return
        threading.Thread(target=self._send, args=(go_home, ident), daemon=True,
                         name=f"go-home-{self.robot}").start()

    def _send(self, go_home: Any, ident: str) -> None:
        try:
            go_home()
        except Exception as exc:  # a link's own error: the robot holds, the operator is told
            log.warning("stand-down %s: sending %s home failed (%s): it holds where it is",
                        ident, self.robot, getattr(exc, "reason", None) or repr(exc))
            return
        log.warning("stand-down %s: %s sent home", ident, self.robot)
