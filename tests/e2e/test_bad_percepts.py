"""Issue 15 item 2, through real processes: the reasoner (under `mrss supervise`) refuses
malformed percepts from the bus — non-ground, sender-set `source(...)`, non-finite,
oversized, deeply nested, exponentiation — with a counted, rate-limited log line and no
traceback; none becomes a belief or an action, and a good percept after them still does.
The reasoner's refusal counters reach the bus (`Rejections`, for the dashboard)."""

from __future__ import annotations

import pytest

from mrss.messages import Rejections
from mrss.testing import wait_until
from tests.e2e.system import System, beliefs

pytestmark = pytest.mark.slow

BAD = [
    "patrol_goal(X, bad1, 2)",
    "patrol_goal(uav2, bad2, 2)[source(self)]",
    "patrol_goal(uav2, bad3, 1e999)",
    'patrol_goal(uav2, bad4, "' + "x" * (1 << 20) + '")',
    "patrol_goal(uav2, bad5, " + "f(" * 5000 + "a" + ")" * 5000 + ")",
    "patrol_goal(uav2, bad6, 9**9**9)",
]


def test_the_reasoner_refuses_malformed_percepts_and_takes_the_next_good_one(
        system: System) -> None:
    for _ in range(3):  # repeated: logged once per reason, counted every time
        for literal in BAD:
            system.percept(literal)
    system.percept("patrol_goal(uav2, good, 1)")

    good = system.request("patrol", "good", timeout=20)  # after every bad one, in order
    assert good.args == ["uav2", "good", 1]
    assert {r.goal for r in system.requests("patrol")} == {"good"}
    snap = system.wait_mind(lambda s: beliefs(s, "patrol_goal("))
    assert beliefs(snap, "patrol_goal(") == ["patrol_goal(uav2,good,1)[source(percept)]"]
    assert system.incarnation("reasoner") == 1  # never died of it

    log = wait_until(lambda: (text := system.log_text()).count("refused percept") >= 6
                     and text, message="the refusals in the log")
    for reason in ("percept not ground", "percept sets its source",
                   "percept not a literal (<term>:1:25: number 1e999 is too large",
                   "percept too large",
                   "percept nested too deeply", "percept has exponentiation"):
        assert log.count(f"refused percept from tester: {reason}") == 1, (reason, [
            line for line in log.splitlines() if "refused percept" in line])
    assert "Traceback" not in log and "RecursionError" not in log

    report = wait_until(lambda: [r for r in system.bodies(Rejections)
                                 if r.component == "reasoner" and r.total == 18],
                        message="the reasoner's refusal counters on the bus")[-1]
    assert report.counts["percept from tester: percept sets its source"] == 3
    assert sum(report.counts.values()) == 18 and len(report.counts) == 6
