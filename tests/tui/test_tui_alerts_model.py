"""The alert rules over bus messages, acknowledgement and history (no Textual)."""

from __future__ import annotations

from mrss.messages import Envelope, Message, Percept, RobotData, RobotState, SupEvent
from mrss.tui.models.alerts import SEVERE, AlertKind, AlertsModel, battery_percent


def env(body: Message, ts: float = 100.0) -> Envelope:
    return Envelope(topic=body.topic(), id="1", ts=ts, src="rcl", inc=0, body=body)


def test_battery_low_is_raised_once_then_resolved_then_raised_again() -> None:
    model = AlertsModel(battery_low=20)
    assert model.apply(env(RobotData(robot="ugv1", data={"type": "battery",
                                                         "remaining": 50}))) == []
    raised = model.apply(env(RobotData(robot="ugv1", data={"type": "battery",
                                                           "remaining": 15})))
    assert [(a.kind, a.subject, a.text) for a in raised] == [
        (AlertKind.BATTERY_LOW, "ugv1", "15%")]
    # still low: no new alert, the detail follows
    assert model.apply(env(RobotData(robot="ugv1", data={"battery": 12}))) == []
    assert model.unacked()[0].text == "12%"
    model.apply(env(RobotData(robot="ugv1", data={"battery": {"remaining": 80}})))
    assert model.unacked()[0].resolved and model.unacked()[0].line().endswith("(over)")
    again = model.apply(env(RobotData(robot="ugv1", data={"battery": 5})))
    assert again and again[0].count == 2 and not again[0].resolved


def test_link_down_and_unavailable_robots() -> None:
    model = AlertsModel()
    raised = model.apply(env(RobotState(robot="uav1", available=False, link="down",
                                        reason="no heartbeat")))
    assert [a.kind for a in raised] == [AlertKind.LINK_DOWN]  # not also "unavailable"
    raised = model.apply(env(RobotState(robot="uav1", available=False, link="up",
                                        reason="quarantined: 3 failures")))
    assert [(a.kind, a.text) for a in raised] == [(AlertKind.UNAVAILABLE,
                                                   "quarantined: 3 failures")]
    assert model.alerts[(AlertKind.LINK_DOWN, "uav1")].resolved
    assert model.apply(env(RobotState(robot="uav1", available=True))) == []
    assert model.alerts[(AlertKind.UNAVAILABLE, "uav1")].resolved


def test_events_hotspot_restart_hang_quarantine_give_up() -> None:
    model = AlertsModel()
    assert model.apply(env(Percept(literal="hotspot_detected(h1,43.6,1.44)")))[0].kind \
        == AlertKind.HOTSPOT
    assert model.apply(env(Percept(literal="hotspot_detected(h1,43.6,1.44)",
                                   op="remove"))) == []
    assert model.apply(env(Percept(literal="fire(area1)"))) == []
    for event, kind in (("restart", AlertKind.RESTARTED), ("hang", AlertKind.HUNG),
                        ("quarantine", AlertKind.QUARANTINED),
                        ("give_up", AlertKind.GAVE_UP)):
        raised = model.apply(env(SupEvent(event=event, child="rcl", supervisor="wf",
                                          reason="boom")))
        assert [(a.kind, a.subject, a.text) for a in raised] == [(kind, "wf/rcl", "boom")]
    assert model.apply(env(SupEvent(event="start", child="rcl"))) == []
    assert model.apply(env(SupEvent(event="restart", child="rcl", supervisor="wf")))[0] \
        .count == 2


def test_acknowledge_clears_the_highlight_keeps_history_and_a_recurrence_reraises() -> None:
    model = AlertsModel()
    model.apply(env(SupEvent(event="restart", child="rcl", supervisor="wf"), ts=1))
    model.apply(env(Percept(literal="hotspot_detected(h2)"), ts=2))
    assert [a.kind for a in model.unacked()] == [AlertKind.HOTSPOT, AlertKind.RESTARTED]
    assert model.acknowledge() == 2
    assert model.unacked() == [] and len(model.history()) == 2
    assert model.acknowledge() == 0
    model.apply(env(SupEvent(event="restart", child="rcl", supervisor="wf"), ts=3))
    assert [(a.kind, a.count) for a in model.unacked()] == [(AlertKind.RESTARTED, 2)]
    assert model.history()[0].kind == AlertKind.RESTARTED  # newest first


def test_battery_percent_reads_both_shapes_and_ignores_junk() -> None:
    assert battery_percent({"type": "battery", "remaining": 42}) == 42.0
    assert battery_percent({"battery": 7.5}) == 7.5
    assert battery_percent({"battery": {"remaining": 3}}) == 3.0
    for junk in ({"type": "position", "battery": 5}, {"battery": "low"},
                 {"battery": True}, {"battery": float("nan")}, {}):
        assert battery_percent(junk) is None


def test_a_lost_node_is_an_alert_until_it_is_back() -> None:
    model = AlertsModel()
    down = SupEvent(event="node_down", child="field", supervisor="node.base",
                    reason="node field down: no heartbeat for 2.0 s", detail={"repeat": False})
    raised = model.apply(env(down))
    assert [(a.kind, a.subject, a.text) for a in raised] == [
        (AlertKind.NODE_DOWN, "node field", down.reason)]
    assert model.apply(env(down)) == []  # its level-triggered repeat: no new alert
    model.apply(env(SupEvent(event="node_up", child="field", supervisor="node.base")))
    assert model.alerts[(AlertKind.NODE_DOWN, "node field")].resolved


def test_a_restart_budget_nearly_used_is_raised_from_the_tree_and_resolved_as_it_drops() -> None:
    model = AlertsModel()

    def tree(rcl: object, reasoner: object) -> Envelope:
        return env(SupEvent(event="tree", child="wf", detail={"tree": {
            "id": "wf", "budget": None, "children": [
                {"id": "rcl", "budget": rcl},
                {"id": "group", "children": [{"id": "reasoner", "budget": reasoner}]},
                "junk", {"id": 3}]}}))

    assert model.apply(tree([3, 5, 30.0], [0, 5, 30.0])) == []  # two restarts left
    raised = model.apply(tree([4, 5, 30.0], [1, 1, 10.0]))  # one left; none left
    assert [(a.kind, a.subject, a.text) for a in raised] == [
        (AlertKind.BUDGET, "wf/rcl", "4 of 5 in 30 s"),
        (AlertKind.BUDGET, "wf/group/reasoner", "1 of 1 in 10 s")]
    assert model.apply(tree([4, 5, 30.0], [1, 1, 10.0])) == []  # still on: one alert
    model.apply(tree([2, 5, 30.0], ["x", 1]))  # the window moved on; a bad report
    assert model.alerts[(AlertKind.BUDGET, "wf/rcl")].resolved
    assert not model.alerts[(AlertKind.BUDGET, "wf/group/reasoner")].resolved


def test_a_goal_that_fails_for_good_is_a_severe_alert_each_time() -> None:
    model = AlertsModel()
    alert = model.goal_failed("a1", "uav1", 5.0)
    assert alert.line() == "goal failed: a1 (uav1)" and alert.kind in SEVERE
    assert model.goal_failed("a1", "uav1", 9.0).count == 2  # sent again, failed again


def test_a_components_own_tree_names_its_actors_under_the_component() -> None:
    model = AlertsModel()
    raised = model.apply(env(SupEvent(event="tree", child="robots", detail={
        "scope": "component", "tree": {"id": "robots", "children": [
            {"id": "uav1", "budget": [2, 2, 10.0]}]}})))  # sent by the RCL (src rcl)
    assert [(a.kind, a.subject) for a in raised] == [(AlertKind.BUDGET, "rcl/robots/uav1")]


def test_the_geofence_percepts_are_conditions_on_the_robot() -> None:
    model = AlertsModel()
    leaving = "geofence_exit(rover1,salt_marsh,39.7712,44.8015117)"
    raised = model.apply(env(Percept(literal=leaving)))
    assert [(a.kind, a.subject, a.text, a.severe) for a in raised] == [
        (AlertKind.NO_GO, "rover1", "in salt_marsh: leaving by 39.7712,44.8015117", False)]
    assert model.apply(env(Percept(literal=leaving, op="remove"))) == []
    assert model.alerts[(AlertKind.NO_GO.value, "rover1")].resolved
    trapped = model.apply(env(Percept(literal='geofence_trapped(rover1,"Salt Marsh")')))
    assert [(a.kind, a.text, a.severe) for a in trapped] == [
        (AlertKind.TRAPPED, "in Salt Marsh: every way out crosses another zone", True)]
    assert model.apply(env(Percept(literal="geofence_exit(broken"))) == []
