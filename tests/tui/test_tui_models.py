"""The dashboard's models and operator checks, without Textual: what each message means."""

from __future__ import annotations

import logging
import os
import subprocess
import sys
from pathlib import Path

import pytest
from rich.text import Text

from mrss.errors import ConfigError
from mrss.messages import ActionRequest, ActionStatus, Percept, RobotData, SupEvent, across_runs
from mrss.tui import operator
from mrss.tui.discovery import find_endpoints
from mrss.tui.models.actions import ActionsModel, ActionView, bar
from mrss.tui.models.liveness import Liveness
from mrss.tui.models.logfilter import LogEntry, LogFilter, LogFilterError
from mrss.tui.models.robots import RobotsModel
from mrss.tui.models.supervision import SupervisionModel
from mrss.tui.widgets.mind_inspector import event_text
from mrss.tui.widgets.supervision_table import uptime_text

PROJECTS = Path(__file__).resolve().parent.parent / "projects"


@pytest.mark.parametrize(("line", "expected"), [
    ("fire(area1)", Percept(literal="fire(area1)")),
    ("  +fire(area1, 3).  ", Percept(literal="fire(area1, 3)")),
    ("-robot_unavailable(uav1)", Percept(literal="robot_unavailable(uav1)", op="remove")),
    ("~smoke(\"north ridge\")[source(ui)]", Percept(literal="~smoke(\"north ridge\")[source(ui)]")),
])
def test_percept_lines_that_parse_become_percepts(line: str, expected: Percept) -> None:
    assert operator.parse_percept(line) == expected


@pytest.mark.parametrize(("line", "error"), [
    ("", "type a literal"),
    ("-", "type a literal"),
    ("fire(area1", "not a literal: it ends too early; expected \")\""),
    ("fire(area1))", "not a literal: column 12: unexpected"),
    ("fire(X)", "must be ground"),
    ("X", "not a literal"),
    ("42", "not a literal"),
    ("a :- b", "not a literal"),
    ("fire(a). fire(b)", "not a literal"),
])
def test_bad_percept_lines_are_refused_with_the_reason(line: str, error: str) -> None:
    with pytest.raises(operator.OperatorError, match=None) as info:
        operator.parse_percept(line)
    assert error in str(info.value)


def test_operator_messages_are_checked() -> None:
    assert operator.fault("rcl", "kill").args == {"fault": "kill"}
    assert operator.fault("rcl", "kill").topic() == "ctl.fault"
    assert operator.teleop("ugv1", True).topic() == "ctl.teleop"
    for bad in (lambda: operator.fault("rcl", "explode"), lambda: operator.fault("", "kill"),
                lambda: operator.action_control("succeed", "u1"),
                lambda: operator.action_control("cancel", ""), lambda: operator.teleop("", True)):
        with pytest.raises(operator.OperatorError):
            bad()


def test_supervision_model_nests_actor_events_under_the_component_that_sent_them() -> None:
    model = SupervisionModel(root="wildfire")
    model.apply_event(SupEvent(event="start", child="rcl", supervisor="wildfire", pid=10,
                               detail={"inc": 1}), "supervisor", 100.0)
    model.apply_event(SupEvent(event="start", child="uav1", supervisor="robots", pid=10,
                               detail={"inc": 1}), "rcl", 101.0)
    model.apply_event(SupEvent(event="start", child="skill-1", supervisor="robots/uav1"),
                      "rcl", 102.0)
    model.apply_event(SupEvent(event="escalate", child="skill-1", supervisor="robots/uav1",
                               reason="crashed: boom"), "rcl", 103.0)
    assert [n.path for n in model.rows()] == [
        "wildfire", "wildfire/rcl", "wildfire/rcl/robots", "wildfire/rcl/robots/uav1",
        "wildfire/rcl/robots/uav1/skill-1"]
    uav1 = model.nodes["wildfire/rcl/robots/uav1"]
    assert (uav1.state, uav1.kind, uav1.uptime(111.0)) == ("escalated", "supervisor", None)
    assert model.nodes["wildfire/rcl"].uptime(111.0) == 11.0
    assert model.nodes["wildfire/rcl/robots/uav1/skill-1"].last_reason == "crashed: boom"
    assert model.is_component("wildfire/rcl")
    assert not model.is_component("wildfire/rcl/robots/uav1")
    assert model.nodes["wildfire/rcl"].kind == "worker"  # a process, even with actors inside
    # the process dies: its actors are gone with it
    model.apply_event(SupEvent(event="exit", child="rcl", supervisor="wildfire", pid=10,
                               reason="killed: SIGKILL"), "supervisor", 120.0)
    skill = model.nodes["wildfire/rcl/robots/uav1/skill-1"]
    assert (skill.state, skill.pid, skill.last_reason) == ("stopped", 0, "rcl exited")
    assert model.nodes["wildfire/rcl"].state == "exited"


def test_a_component_given_up_alone_is_marked_and_the_root_runs_on() -> None:
    model = SupervisionModel(root="wildfire")
    for child in ("bus", "reasoner", "rcl"):
        model.apply_event(SupEvent(event="start", child=child, supervisor="wildfire", pid=10),
                          "supervisor", 100.0)
    model.apply_event(SupEvent(event="give_up", child="reasoner", supervisor="wildfire",
                               reason="killed: SIGKILL", detail={
                                   "stops": "component", "members": ["reasoner", "rcl"]}),
                      "supervisor", 101.0)
    states = {n.path: n.state for n in model.rows()}
    assert states["wildfire/reasoner"] == states["wildfire/rcl"] == "gave up"
    assert states["wildfire/bus"] == "running" and states["wildfire"] != "gave up"
    assert model.nodes["wildfire/reasoner"].last_reason == "killed: SIGKILL"


def test_supervision_model_has_a_level_per_node_and_marks_a_lost_nodes_components() -> None:
    model = SupervisionModel()
    for node, child in (("base", "rcl"), ("field", "beacon")):
        model.apply_event(SupEvent(event="start", child=child, supervisor="demo", pid=10,
                                   node=node), "supervisor", 100.0)
    model.apply_event(SupEvent(event="start", child="ugv1", supervisor="robots", node="base"),
                      "rcl", 101.0)
    model.apply_event(SupEvent(event="tree", child="demo", node="field", detail={"tree": {
        "id": "demo", "children": [{"id": "bus", "state": "running"}]}}), "supervisor", 102.0)
    assert [n.path for n in model.rows()] == [
        "demo", "demo/base", "demo/base/rcl", "demo/base/rcl/robots",
        "demo/base/rcl/robots/ugv1", "demo/field", "demo/field/beacon", "demo/field/bus"]
    assert model.nodes["demo/field"].kind == "node"
    assert model.is_component("demo/field/beacon") and not model.is_component("demo/field")
    lost = SupEvent(event="node_down", child="field", supervisor="node.base", node="base",
                    reason="node field down: no heartbeat for 1.0 s",
                    detail={"state": "down", "components": ["beacon", "relay"]})
    model.apply_event(lost, "node.base", 103.0)
    states = {n.path: (n.state, n.last_reason) for n in model.rows()}
    assert states["demo/field"] == ("down", lost.reason)
    assert states["demo/field/beacon"] == states["demo/field/relay"] == ("node down",
                                                                         lost.reason)
    assert states["demo/base/rcl"][0] == "running"
    model.apply_event(SupEvent(event="node_up", child="field", supervisor="node.base",
                               node="base", detail={"state": "up"}), "node.base", 104.0)
    assert model.nodes["demo/field"].state == "up"
    assert model.nodes["demo/field/beacon"].state == "running"  # as before the loss


def test_a_peer_nodes_component_shows_its_incarnation_as_its_root_counts() -> None:
    """Base's border numbers field's incarnations by field's run (docs/bus.md); the
    dashboard shows them as field's root counts them, as field's tree does."""
    model = SupervisionModel()
    model.apply_event(SupEvent(event="start", child="beacon", supervisor="demo", pid=10,
                               node="field", detail={"inc": across_runs(1_800_000_000_000, 2)}),
                      "supervisor", 100.0)
    assert model.nodes["demo/field/beacon"].incarnation == 2


def test_a_components_own_tree_hangs_under_the_component() -> None:
    model = SupervisionModel()
    model.apply_event(SupEvent(event="tree", child="demo", detail={"tree": {
        "id": "demo", "children": [{"id": "rcl", "state": "running"}]}}), "supervisor", 1.0)
    model.apply_event(SupEvent(event="tree", child="robots", detail={"scope": "component",
        "tree": {"id": "robots", "kind": "supervisor", "state": "running", "children": [
            {"id": "uav1", "kind": "worker", "state": "running", "restarts": 2}]}}),
        "rcl", 2.0)
    assert [n.path for n in model.rows()] == ["demo", "demo/rcl", "demo/rcl/robots",
                                              "demo/rcl/robots/uav1"]
    assert model.nodes["demo/rcl/robots/uav1"].restarts == 2


def test_siblings_follow_their_supervisors_order_once_a_tree_came() -> None:
    """A late dashboard may hear the RCL's own events before the root's tree: the tree's
    order (the supervisor's start order) wins over the order heard."""
    model = SupervisionModel()
    model.apply_event(SupEvent(event="start", supervisor="demo", child="rcl", pid=7),
                      "supervisor", 1.0)
    model.apply_event(SupEvent(event="start", supervisor="demo", child="reasoner", pid=8),
                      "supervisor", 1.0)
    assert [n.path for n in model.rows()] == ["demo", "demo/rcl", "demo/reasoner"]
    model.apply_event(SupEvent(event="tree", child="demo", detail={"tree": {
        "id": "demo", "children": [{"id": "bus"}, {"id": "rcl"}, {"id": "reasoner"}]}}),
        "supervisor", 2.0)
    assert [n.path for n in model.rows()] == ["demo", "demo/bus", "demo/rcl",
                                              "demo/reasoner"]


def test_supervision_model_ignores_malformed_tree_snapshots() -> None:
    model = SupervisionModel()
    model.apply_event(SupEvent(event="tree", child="x", detail={"tree": {"id": 3}}), "s", 1.0)
    model.apply_event(SupEvent(event="tree", child="x", detail={"tree": [1, 2]}), "s", 1.0)
    model.apply_event(SupEvent(event="tree", child="x", detail={"tree": {
        "id": "demo", "pid": "many", "children": [{"id": "a", "state": 5}, "junk"]}}), "s", 1.0)
    assert [n.path for n in model.rows()] == ["demo", "demo/a"]
    assert model.nodes["demo"].pid == 0 and model.nodes["demo/a"].state == "?"


def test_the_restart_budget_is_the_supervisors_own_count_when_its_tree_reports_one() -> None:
    """Restarts from before the dashboard attached count: the supervisor says them."""
    model = SupervisionModel()

    def tree(budget: object) -> SupEvent:
        return SupEvent(event="tree", child="demo", detail={"tree": {
            "id": "demo", "state": "running", "children": [
                {"id": "rcl", "state": "running", "restarts": 3, "budget": budget}]}})

    model.apply_event(tree(None), "demo", 1.0)
    rcl = model.nodes["demo/rcl"]
    assert rcl.budget_text(1.0, 5, 10.0) == "0 of 5 in 10 s (seen since attached)"
    model.apply_event(tree([3, 5, 30.0]), "demo", 2.0)
    assert rcl.budget_text(2.0, 5, 10.0) == "3 of 5 in 30 s"
    for junk in ([1, 2], ["3", 5, 30], [3, 5, 0], [-1, 5, 30], [True, 5, 30]):
        model.apply_event(tree(junk), "demo", 3.0)
        assert rcl.budget == (3, 5, 30.0)  # a bad report keeps what was known
    # a restart heard before the next tree counts at once
    model.apply_event(SupEvent(event="restart", child="rcl", supervisor="demo", count=4),
                      "supervisor", 4.0)
    assert rcl.budget_text(4.0, 5, 10.0) == "4 of 5 in 30 s"
    model.apply_event(SupEvent(event="restart", child="rcl", supervisor="demo", count=4),
                      "supervisor", 4.5)
    assert rcl.budget == (4, 5, 30.0)  # the same restart heard twice counts once


def test_robots_model_merges_flat_telemetry_and_keeps_the_latest_record_per_type() -> None:
    model = RobotsModel()
    model.apply_data(RobotData(robot="r", data={"lat": 1.0, "lon": 2.0, "battery": 50}), 1.0)
    model.apply_data(RobotData(robot="r", data={"battery": 40, "tank": {"level": 3,
                                                                       "capacity": 10}}), 2.0)
    view = model.robots["r"]
    assert (view.position(), view.battery(), view.tank()) == ("1.00000, 2.00000", "40%",
                                                              "3.0/10.0 L")
    model.apply_data(RobotData(robot="r", data={"type": "battery", "remaining": 39.6}), 3.0)
    model.apply_data(RobotData(robot="r", data={"type": "position", "lat": "x", "lon": 1}), 3.0)
    assert (view.battery(), view.position()) == ("40%", "")


def test_actions_model_forgets_finished_actions_first_when_full() -> None:
    model = ActionsModel(limit=10)
    for i in range(10):
        model.apply_status(ActionStatus(uuid=f"u{i}", state="running"), float(i))
    for i in range(0, 10, 2):
        model.apply_status(ActionStatus(uuid=f"u{i}", state="succeeded"), 20.0)
    model.apply_request(ActionRequest(uuid="new", name="go", args=[1]), 30.0)
    kept = {a.uuid for a in model.actions.values()}
    assert "new" in kept and len(kept) == 9
    assert {f"u{i}" for i in range(1, 10, 2)} <= kept  # every running one is still there
    assert model.newest_first()[0].uuid == "new"
    assert model.actions["new"].state == "requested"


def test_small_formatters() -> None:
    assert [uptime_text(s) for s in (None, 5, 65, 7260)] == ["", "5s", "1m05s", "2h01m"]
    assert event_text("+!go(a)  (intention #4)") == "+!go(a)  (intention #4)"


def test_discovery_finds_the_bus_from_flags_run_dir_or_the_newest_temp_run_dir(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MRSS_PROJECTS", str(PROJECTS))
    ep, name = find_endpoints("anything", endpoints=["tcp://127.0.0.1:5601",
                                                     "tcp://127.0.0.1:5602"])
    assert (ep.backend, name) == ("tcp://127.0.0.1:5602", "anything")
    ep, name = find_endpoints("busdemo", run_dir=tmp_path)
    assert (ep.backend, name) == (f"ipc://{tmp_path}/bus-sub.sock", "busdemo")
    with pytest.raises(ConfigError, match="no running system of 'busdemo' found"):
        find_endpoints("busdemo", temp_dir=tmp_path)
    for stamp, run in ((1000, "mrss-busdemo-old"), (2000, "mrss-busdemo-new")):
        (tmp_path / run).mkdir()
        (tmp_path / run / "bus-sub.sock").touch()
        os.utime(tmp_path / run / "bus-sub.sock", (stamp, stamp))
    (tmp_path / "mrss-busdemo-nosocket").mkdir()
    ep, _ = find_endpoints("busdemo", temp_dir=tmp_path)
    assert ep.backend == f"ipc://{tmp_path}/mrss-busdemo-new/bus-sub.sock"


def test_mrss_tui_without_a_running_system_exits_2_with_a_hint(tmp_path: Path) -> None:
    env = {**os.environ, "MRSS_PROJECTS": str(PROJECTS), "TMPDIR": str(tmp_path)}
    for args, message in ((["busdemo"], "pass --run-dir"),
                          (["nosuchproject"], "unknown project 'nosuchproject'")):
        proc = subprocess.run([sys.executable, "-m", "mrss", "tui", *args], env=env,
                              capture_output=True, text=True, timeout=60)
        assert proc.returncode == 2, proc.stderr
        assert message in proc.stderr


def test_liveness_banner_says_what_is_wrong_most_serious_first() -> None:
    now = [100.0]
    live = Liveness(stale_after=5.0, clock=lambda: now[0])
    assert live.banner(connected=False) == "waiting for the bus proxy"
    assert live.banner(connected=True) == ""  # just started
    now[0] = 106.0
    assert live.banner(connected=True) == "nothing heard from the system in 6 s"
    live.heard()
    assert live.banner(connected=True) == ""
    now[0] = 118.0
    assert live.banner(connected=True).startswith("no heartbeat for 12 s")
    live.end("demo gave up: rcl: too many restarts")
    live.end("system stopped (exit 1)")  # the first reason stays
    live.heard()
    assert live.banner(connected=False) == "demo gave up: rcl: too many restarts"


def test_log_filter_by_level_component_and_words() -> None:
    def entry(text: str, level: int = logging.INFO, component: str = "") -> LogEntry:
        return LogEntry(Text(f"12:00:00 {text}"), level, component)

    warn = entry("WARN rcl: journal slow", logging.WARNING, "rcl")
    info = entry("INFO reasoner: plan 12 selected", logging.INFO, "reasoner")
    assert LogFilter.parse("").matches(warn) and not LogFilter.parse("").active
    assert [LogFilter.parse(f).matches(e) for f in ("level:warn", "l:e", "@rcl", "comp:reas",
                                                     "journal SLOW", "12")
            for e in (warn, info)] == [True, False, False, False, True, False, False, True,
                                       True, False, False, True]
    with pytest.raises(LogFilterError, match="unknown level 'loud'"):
        LogFilter.parse("level:loud")
    with pytest.raises(LogFilterError, match="comp: needs a component"):
        LogFilter.parse("comp:")


def test_progress_with_a_known_count_is_a_bar_and_other_keys_follow() -> None:
    view = ActionView("u", 0, progress={"waypoint": 6, "waypoints": 12, "eta": 41.25})
    assert view.progress_text() == "6/12 █████░░░░░ eta=41.2"
    assert ActionView("u", 0, progress={"leg": 0, "of": 4}).progress_text() == "0/4 ░░░░░░░░░░"
    # not a count: as key=value
    assert ActionView("u", 0, progress={"waypoint": 2, "of": 0}).progress_text() == \
        "waypoint=2 of=0"
    assert ActionView("u", 0, progress={"pumped": 12.5}).progress_text() == "pumped=12.5"
    assert bar(1.5, 4) == "████" and bar(-1, 4) == "░░░░"
