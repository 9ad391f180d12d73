"""The AMADEE agent's decisions, on the real interpreter with a scripted host: no action
reaches the robot before the data layer found it legal, and a refusal names its rule."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from mrss.api.testing import ScriptedHost

AGENT = Path(__file__).resolve().parent.parent / "agent.asl"


def verdicts(table: dict[str, list[str]]) -> Any:
    """Answer `legal` by the action's goal (its second argument)."""
    return lambda action: table[str(action).rstrip(")").split(",")[1]]


def test_a_legal_request_is_checked_first_then_sent() -> None:
    host = ScriptedHost(answers={"legal": verdicts({"g1": ["legal"], "g2": ["legal"]})})
    host.load(AGENT, name="amadee")
    host.feed("drive_received(g1, 39.7705, 44.8)")
    assert host.log == ["query(legal,[drive(rover1,g1,39.7705,44.8)],V)",
                        "drive(rover1,g1,39.7705,44.8)"]
    host.finish("drive(rover1,g1,39.7705,44.8)")
    host.feed("science_received(g2, sample)")
    assert host.log[2:] == ["query(legal,[sample(rover1,g2)],V)", "sample(rover1,g2)"]


def test_an_illegal_request_is_refused_with_its_rule_and_nothing_is_sent() -> None:
    host = ScriptedHost(answers={"legal": verdicts({
        "g3": ["illegal", "no_go_path", "the path crosses no_go zone 'salt_marsh'"]})})
    agent = host.load(AGENT, name="amadee")
    host.feed("drive_received(g3, 39.7725, 44.801)")
    assert host.log == ["query(legal,[drive(rover1,g3,39.7725,44.801)],V)"]
    assert agent.believes('refused(g3, "no_go_path")')
    assert not host.open


def test_home_and_every_science_task_are_checked() -> None:
    host = ScriptedHost(answers={"legal": lambda action: ["legal"]})
    host.load(AGENT, name="amadee")
    host.feed("home_received(h1)")
    for n, what in enumerate(("image", "spectrum", "radar"), 2):
        host.feed(f"science_received(s{n}, {what})")
    queried = [a for a in host.log if a.startswith("query(legal")]
    assert queried == ["query(legal,[return_home(rover1,h1)],V)",
                       "query(legal,[image(rover1,s2)],V)",
                       "query(legal,[spectrum(rover1,s3)],V)",
                       "query(legal,[radar(rover1,s4)],V)"]


def test_the_rover_found_inside_a_no_go_zone_leaves_by_the_way_out_and_then_resumes() -> None:
    host = ScriptedHost(answers={"legal": lambda action: ["legal"]})
    agent = host.load(AGENT, name="amadee")
    host.feed("geofence_exit(rover1, salt_marsh, 39.77099, 44.801)")
    assert host.log == ["query(legal,[drive(rover1,geofence,39.77099,44.801)],V)",
                        "drive(rover1,geofence,39.77099,44.801)"]
    host.feed("drive_received(g1, 39.7705, 44.8)")      # work while it is still inside
    assert len(host.log) == 2 and agent.believes("geofence_exit(rover1, salt_marsh, _, _)")
    host.finish("drive(rover1,geofence,")
    host.feed("-geofence_exit(rover1, salt_marsh, 39.77099, 44.801)")   # seen out
    assert host.log[2:] == ["query(legal,[drive(rover1,g1,39.7705,44.8)],V)",
                            "drive(rover1,g1,39.7705,44.8)"]


def test_a_trapped_rover_is_not_moved() -> None:
    host = ScriptedHost(answers={"legal": lambda action: ["legal"]})
    host.load(AGENT, name="amadee")
    host.feed("geofence_trapped(rover1, inner)")
    assert host.log == [] and not host.open
