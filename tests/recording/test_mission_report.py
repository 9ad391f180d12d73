"""`mrss recording report` on a real recording of the wildfire procedure (conftest.py: an
operator's area goal, a killed component, the operator's teleop of the UGV, the hotspot
the world model sends the UGV to once it is back); the recording's world.geojson shows
the area and the hotspot."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from mcap.reader import make_reader

from mrss.recording.mission_figures import first_argument
from tests.commands.cli_bus import mrss


def test_a_goals_name_is_its_percepts_first_argument() -> None:
    assert first_argument("hotspot_detected(hs1, -35.3, 149.1)") == "hs1"
    assert first_argument('area_goal_received("a1", 2)') == "a1"
    assert first_argument("hold_all") is None


@pytest.mark.slow
def test_report_of_a_wildfire_recording(wildfire_recording: Path) -> None:
    out = wildfire_recording
    report = mrss("recording", "report", str(out), "--format", "json")
    assert report.returncode == 0, report.stderr
    data = json.loads(report.stdout)
    assert data["project"] == "wildfire" and data["warnings"] == []
    goals = {g["goal"]: g for g in data["goals"] if g["reported"] is not None}
    assert set(goals) == {"a1", "hs1"}, data["goals"]
    area, hotspot = goals["a1"], goals["hs1"]
    assert area["robots"] == ["uav1"] and hotspot["robots"] == ["ugv2"]  # ugv1: teleop
    for goal in (area, hotspot):
        assert goal["outcome"] == "done"
        assert 0 <= goal["to_first_action"] < goal["to_done"]
    assert hotspot["reported"] > area["reported"]  # found while covering the area
    assert area["interventions"] == 0
    # the teleop on and off name the UGV: each counts against hs1 only if it came while
    # hs1 was open, which is the run's timing, not the test's
    assert 0 <= hotspot["interventions"] <= 2
    without = sum(1 for g in (area, hotspot) if g["interventions"] == 0)
    assert data["goals_reported"] == 2 and data["goals_done"] == 2
    assert data["goals_done_without_operator"] == without
    assert data["share_done_without_operator"] == without / 2
    interventions = [i["what"] for i in data["interventions"]]
    assert len(interventions) == 2 and all(i.startswith("mrss/ui/teleop") for i in
                                           interventions), interventions
    assert data["interventions_per_hour"] == pytest.approx(2 / (data["span_s"] / 3600))
    actions = {(a["robot"], a["state"]): a["count"] for a in data["actions"]}
    assert actions[("uav1", "succeeded")] >= 1
    assert actions[("ugv1", "succeeded")] >= 2  # teleop on, teleop off
    assert actions[("ugv2", "succeeded")] >= 1  # the supply
    assert data["restarts"].get("events") == 1
    assert {"event": "exit", "component": "events", "count": 1} in data["faults"]
    assert data["robot_losses"] == []

    text = mrss("recording", "report", str(out))
    assert text.returncode == 0, text.stderr
    assert f"goals: 2 reported, 2 done, {without} done without an operator " \
           f"({100 * without // 2} % of the goals reported)" in text.stdout
    assert "operator interventions: 2 (" in text.stdout

    # The map's channel: the operator's area and the hotspot the UAV found, latest state.
    with out.open("rb") as handle:
        shapes = [json.loads(json.loads(m.data)["geojson"]) for _, _, m in
                  make_reader(handle).iter_messages(topics=["world.geojson"])]
    assert shapes, "no world.geojson message"
    last = {f["id"]: f for f in shapes[-1]["features"]}
    assert last["a1"]["geometry"]["type"] == "Point"  # a centre and a radius, as stored
    assert last["a1"]["properties"]["radius_m"] == 100
    assert last["hs1"]["geometry"]["type"] == "Point"
    assert last["hs1"]["properties"]["kind"] == "hotspot"
    assert "uav1" not in last and "ugv1" not in last
