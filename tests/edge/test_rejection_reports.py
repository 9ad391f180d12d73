"""A component's refusal counters as `Rejections` bus messages (mrss.edge.rejection_reports):
published when they moved, at most every REPORT_EVERY seconds, the commonest kinds."""

from __future__ import annotations

import logging

from mrss.edge.rejection_reports import MAX_KINDS, RejectionReporter
from mrss.edge.rejections import RejectionLog, process_counts
from mrss.links.mavlink_signing import Refusal, Signing
from mrss.messages import Message, Rejections, decode, encode


class Clock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def test_reports_only_moved_counters_and_at_most_every_interval() -> None:
    counts: dict[str, int] = {}
    sent: list[Message] = []
    clock = Clock()
    reporter = RejectionReporter("rcl", sent.append, every=2.0, repeat=30.0,
                                 counts=lambda: dict(counts), clock=clock)
    assert reporter.tick() is None and sent == []  # nothing refused: nothing said
    counts["telemetry record from uav1: position.lat out of range"] = 1
    first = reporter.tick()
    assert first == Rejections(component="rcl", total=1, counts=counts) and sent == [first]
    counts["telemetry record from uav1: position.lat out of range"] = 5
    clock.now += 1.0
    assert reporter.tick() is None  # too soon
    clock.now += 1.0
    second = reporter.tick()
    assert second is not None and second.total == 5 and len(sent) == 2
    clock.now += 10.0
    assert reporter.tick() is None and len(sent) == 2  # unchanged: not repeated ...
    clock.now += 20.0
    assert reporter.tick() == second and len(sent) == 3  # ... until `repeat` has passed
    for n in range(MAX_KINDS + 5):
        counts[f"percept from s{n}: percept not ground"] = n + 1
    clock.now += 2.0
    third = reporter.tick()
    assert third is not None and len(third.counts) == MAX_KINDS
    assert third.total == sum(counts.values())
    assert min(third.counts.values()) == 6  # the commonest kinds are named
    assert decode(*encode(third, src="rcl")).body == third  # a valid bus message


def test_process_counts_add_up_every_live_counter_of_the_process() -> None:
    before = process_counts()
    log = RejectionLog(logging.getLogger("test.reports"), "robot data")
    log.reject("fz9", "unknown robot")
    log.reject("fz9", "unknown robot")
    signing = Signing(b"\x01" * 32, link_id=1, name="uav7")
    signing.count(Refusal.UNSIGNED)
    after = process_counts()
    assert after.get("robot data from fz9: unknown robot", 0) \
        - before.get("robot data from fz9: unknown robot", 0) == 2
    assert after["MAVLink message from uav7: unsigned"] == 1
    assert signing.totals()["unsigned"] == 1
