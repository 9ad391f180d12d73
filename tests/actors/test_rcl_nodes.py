"""Robots reached through a node (`node` in a robot's table, mrss.config.nodes): the node lost
fails their actions with node_down and refuses new ones; a link report meanwhile does
not hide the node's loss; the node back makes them available; repeats change nothing."""

from __future__ import annotations

from mrss.messages import ActionStatus, RobotState
from mrss.testing import wait_until
from tests.actors.rcl_sim import RclEnv, request_fields


def _last_state(rcl_env: RclEnv, robot: str) -> RobotState:
    return [m for m in rcl_env.statuses.others
            if isinstance(m, RobotState) and m.robot == robot][-1]


def test_a_lost_node_makes_its_robots_unavailable_until_it_is_back(rcl_env: RclEnv) -> None:
    core = rcl_env.start()
    core.availability.robot_nodes = {"ugv1": "field", "ugv2": "field"}  # uav1: on no node
    for uuid, robot in (("a1", "ugv1"), ("a2", "uav1")):
        core.submit_fields(request_fields(uuid, "patrol", robot, "g", ["p1", "p2", "p3"]))
        wait_until(rcl_env.statuses.reached(uuid, "running"))
    assert core.availability.node_state(
        "field", False, "node field down: no heartbeat for 2.0 s") == ["a1"]
    wait_until(rcl_env.statuses.reached("a1", "failed"))
    failed = rcl_env.statuses.last("a1")
    assert failed is not None and failed.cause == "node_down"
    assert "reached through node field, which is lost" in failed.reason
    assert rcl_env.statuses.states("a2") == ["pending", "running"]
    state = _last_state(rcl_env, "ugv1")
    assert not state.available and state.reason.startswith("node down: node field down")
    assert core.availability.node_state("field", False, "again") == []  # the level-triggered repeat
    core.availability.link_state("ugv1", False, "no heartbeat for 3.0 s")  # its link notices too
    core.availability.link_state("ugv1", True)  # ... and a link report does not make it available
    assert not _last_state(rcl_env, "ugv1").available
    core.submit_fields(request_fields("a3", "patrol", "ugv1", "g", ["p1"]))
    wait_until(rcl_env.statuses.reached("a3", "failed"))
    refused = rcl_env.statuses.last("a3") or ActionStatus(uuid="x", state="failed")
    assert refused.cause == "node_down"
    core.availability.node_state("field", True)
    wait_until(lambda: _last_state(rcl_env, "ugv1").available, message="ugv1 back")
    assert _last_state(rcl_env, "ugv2").available
    core.submit_fields(request_fields("a4", "patrol", "ugv1", "g", ["p1"]))
    wait_until(rcl_env.statuses.reached("a4", "running"))
