"""Fault injection into real component processes under the root supervisor."""

from __future__ import annotations

import math
import signal
import threading

import psutil
import pytest

from mrss.supervision import faults
from mrss.supervision.spec import Backoff, Strategy
from mrss.testing import process_gone, wait_until
from tests.faults.conftest import MakeTree, worker


@pytest.mark.parametrize(("strategy", "expected"), [
    (Strategy.ONE_FOR_ONE, {"a": 1, "b": 2, "c": 1}),
    (Strategy.REST_FOR_ONE, {"a": 1, "b": 2, "c": 2}),
    (Strategy.ONE_FOR_ALL, {"a": 2, "b": 2, "c": 2}),
])
def test_sigkill_restarts_the_children_the_strategy_names(
        make_tree: MakeTree, strategy: Strategy, expected: dict[str, int]) -> None:
    tree = make_tree(worker("a"), worker("b"), worker("c"), strategy=strategy)
    before = {c.id: c.pid for c in tree.sup.tree().children}
    killed = faults.kill(tree.sup, "b")
    wait_until(lambda: tree.all_running() and tree.incarnations() == expected, timeout=15,
               message=f"incarnations {expected}")
    after = {c.id: c.pid for c in tree.sup.tree().children}
    for cid, inc in expected.items():
        assert (after[cid] == before[cid]) == (inc == 1), cid
    assert process_gone(killed)
    (exit_b,) = [e for e in tree.log.of("exit", "b") if e.pid == killed]
    assert exit_b.reason == "killed: SIGKILL"
    (restart,) = tree.log.of("restart")
    assert restart.child == "b" and restart.count == 1
    assert restart.detail["group"] == [c for c, i in expected.items() if i == 2]
    assert tree.sup.ping("b")


def test_sigkill_restart_with_exec_launcher(make_tree: MakeTree) -> None:
    tree = make_tree(worker("a"), worker("b"), launcher="exec")
    faults.kill(tree.sup, "a")
    wait_until(lambda: tree.all_running() and tree.incarnations() == {"a": 2, "b": 1},
               timeout=15)
    assert tree.sup.ping("a")


def test_sigstopped_child_is_detected_as_hung_killed_and_replaced(make_tree: MakeTree) -> None:
    tree = make_tree(worker("a"), worker("b"))
    stopped = faults.hang(tree.sup, "b")
    (exit_,) = tree.log.wait_for("exit", "b", timeout=10)
    assert exit_.pid == stopped and exit_.reason.startswith("hung: no heartbeat for")
    wait_until(lambda: tree.all_running() and tree.incarnations()["b"] == 2, timeout=10)
    wait_until(lambda: not psutil.pid_exists(stopped), timeout=5, message="hung pid reaped")
    assert tree.incarnations()["a"] == 1


def test_child_crashing_at_start_backs_off_then_the_root_gives_up(make_tree: MakeTree) -> None:
    tree = make_tree(worker("ok"), worker("bad", crash_on_start=True), intensity=3,
                     backoff=Backoff(initial=0.1, factor=2.0, cap=1.0, jitter=0.0), wait=False)
    outcome = tree.sup.wait(timeout=20)
    assert outcome is not None and outcome.gave_up
    assert outcome.child == "bad"
    assert outcome.reason == "crashed: RuntimeError in start: bad refuses to start"
    assert "more than 3 restarts" in str(outcome)
    delays = [e.detail["delay"] for e in tree.log.of("restart", "bad")]
    assert delays == [0.0, 0.1, 0.2]
    exits = [t for t, e in tree.log.timed() if e.event == "exit" and e.child == "bad"]
    gaps = [b - a for a, b in zip(exits, exits[1:], strict=False)]
    assert gaps[1] >= 0.1 and gaps[2] >= 0.2 and gaps[2] > gaps[0]
    (give_up,) = tree.log.of("give_up")
    assert give_up.child == "bad"
    assert [e.reason for e in tree.log.of("exit", "ok")] == ["shutdown: stopped by supervisor"]


def test_transient_child_that_exits_normally_is_not_restarted(make_tree: MakeTree) -> None:
    tree = make_tree(worker("job", restart="transient", finish_after=0.2),
                     worker("svc", restart="permanent", finish_after=0.2))
    tree.log.wait_for("restart", "svc")
    (job_exit,) = tree.log.wait_for("exit", "job")
    assert job_exit.reason == "normal: exit code 0"
    wait_until(lambda: tree.sup.tree().find("job").state == "stopped",  # type: ignore[union-attr]
               timeout=5)
    assert tree.log.of("restart", "job") == []
    assert tree.log.of("exit", "svc")[0].reason == "normal: exit code 0"


def test_slow_start_past_the_start_timeout_is_killed_and_retried(make_tree: MakeTree) -> None:
    tree = make_tree(worker("a", start_timeout=0.5))
    faults.slow_start(tree.sup, "a", 5.0)
    faults.kill(tree.sup, "a")
    timeout_exit = wait_until(
        lambda: [e for e in tree.log.of("exit", "a") if e.reason.startswith("start_timeout")],
        timeout=10)
    assert timeout_exit[0].reason == "start_timeout: not ready within 0.5s"
    # retried with twice the time, and up; a loaded machine may need more than 1 s to
    # start even without the fault (then one more retry, with 2 s)
    wait_until(lambda: tree.all_running() and tree.incarnations()["a"] >= 3, timeout=10)


def test_a_start_slower_than_its_timeout_every_time_is_given_twice_the_time_each_retry(
        make_tree: MakeTree) -> None:
    # A slow or loaded host: every start takes 1.2 s against a start_timeout of 0.5 s. The
    # supervisor doubles the patience after each start killed for it (0.5, 1, 2 s) instead
    # of killing the same slow start for ever; once up, the next start has 0.5 s again.
    tree = make_tree(worker("a", start_timeout=0.5, start_delay=1.2), wait=False)
    wait_until(lambda: tree.all_running(), timeout=60, message="a running at last")
    reasons = [e.reason for e in tree.log.of("exit", "a")]
    # at least the first two starts were too slow; a loaded machine may need one more
    assert len(reasons) >= 2 and reasons == [
        f"start_timeout: not ready within {0.5 * 2 ** k:g}s" for k in range(len(reasons))]
    assert tree.incarnations()["a"] == len(reasons) + 1


def test_crash_fault_reports_the_childs_own_reason(make_tree: MakeTree) -> None:
    tree = make_tree(worker("a"))
    faults.crash(tree.sup, "a")
    (exit_,) = tree.log.wait_for("exit", "a")
    assert exit_.reason == "crashed: InjectedFault: injected crash"
    wait_until(lambda: tree.incarnations()["a"] == 2 and tree.all_running(), timeout=10)


def test_child_ignoring_its_shutdown_time_is_killed(make_tree: MakeTree) -> None:
    tree = make_tree(worker("slow", shutdown=0.3, stop_delay=30), worker("quick"))
    outcome = tree.sup.stop(timeout=20)
    assert outcome is not None and not outcome.gave_up
    reasons = {e.child: e.reason for e in tree.log.of("exit")}
    assert reasons == {"slow": "shutdown: killed after shutdown 0.3s",
                       "quick": "shutdown: stopped by supervisor"}
    assert [e.child for e in tree.log.of("exit")] == ["quick", "slow"]


def test_fork_server_loss_is_one_launcher_restart_and_its_children_keep_running(
        make_tree: MakeTree) -> None:
    tree = make_tree(worker("a"), worker("b"), intensity=1)
    pids = {c.id: c.pid for c in tree.sup.tree().children}
    (server,) = {psutil.Process(pid).ppid() for pid in pids.values()}
    psutil.Process(server).send_signal(signal.SIGKILL)
    (lost,) = tree.log.wait_for("restart", "forkserver", timeout=10)
    assert lost.reason == "killed: closed its channel (killed: SIGKILL)"
    assert lost.count == 1 and lost.detail["kept"] == 2
    (new_server,) = tree.log.wait_for("start", "forkserver", timeout=10)
    assert new_server.pid not in (0, server) and psutil.pid_exists(new_server.pid)
    # not a failure of its children: same processes, same incarnations, nothing counted
    assert {c.id: c.pid for c in tree.sup.tree().children} == pids
    assert tree.all_running() and tree.incarnations() == {"a": 1, "b": 1}
    assert tree.sup.ping("a") and tree.sup.ping("b")
    assert tree.log.of("exit") == [] and [e.child for e in tree.log.of("restart")] == [
        "forkserver"]
    # a child of the lost server is still watched: its exit is seen and it is restarted,
    # now by the new fork server
    faults.kill(tree.sup, "a")
    (exit_a,) = tree.log.wait_for("exit", "a", timeout=10)
    assert exit_a.pid == pids["a"]
    assert exit_a.reason == "exited: exit status unknown (its fork server was lost)"
    wait_until(lambda: tree.all_running() and tree.incarnations() == {"a": 2, "b": 1},
               timeout=15, message="a restarted")
    assert psutil.Process(tree.sup.pid_of("a")).ppid() == new_server.pid
    (restart_a,) = tree.log.of("restart", "a")
    assert restart_a.count == 1  # intensity 1: the fork server's loss did not count


def test_quarantined_component_is_retried_after_probation_while_others_run(
        make_tree: MakeTree) -> None:
    from mrss.supervision.spec import OnExceeded

    tree = make_tree(worker("uav_link"), worker("ugv_link"), intensity=0,
                     on_exceeded=OnExceeded.QUARANTINE, probation=3.0)  # the checks
    faults.kill(tree.sup, "uav_link")                              # come within it
    (q,) = tree.log.wait_for("give_up", "uav_link")
    assert q.reason == "killed: SIGKILL" and q.detail["retry_in"] == 3.0
    assert q.detail["stops"] == "component" and q.detail["members"] == ["uav_link"]
    assert tree.sup.tree().find("uav_link").state == "quarantined"  # type: ignore[union-attr]
    assert tree.sup.ping("ugv_link") and tree.incarnations()["ugv_link"] == 1
    tree.log.wait_for("release", "uav_link", timeout=30)
    wait_until(lambda: tree.all_running() and tree.incarnations()["uav_link"] == 2, timeout=10)
    assert tree.sup.outcome is None  # the root never stopped
    assert tree.log.of("quarantine") == []  # that word is for robots (robot_unavailable)


def test_supervisor_loop_sleeps_while_a_child_is_slow_to_start(make_tree: MakeTree) -> None:
    # Regression: a waiting child's due start time made the loop spin with a zero timeout
    # for as long as the child before it took to start, burning a core on a 2-core box.
    tree = make_tree(worker("slow", start_delay=1.5), worker("next"), wait=False)
    loop = next(t for t in threading.enumerate() if t.name == "sup-root")

    def cpu_seconds() -> float:
        return next(t.user_time + t.system_time for t in psutil.Process().threads()
                    if t.id == loop.native_id)

    wait_until(lambda: "starting" in {c.state for c in tree.sup.tree().children}, timeout=10,
               message="slow starting")
    before = cpu_seconds()
    wait_until(tree.all_running, timeout=30, message="both running")
    assert tree.incarnations() == {"slow": 1, "next": 1}
    assert cpu_seconds() - before < 0.3  # a spinning loop takes most of the 1.5 s


def test_a_group_restarts_as_a_whole_then_is_given_up_as_one_while_the_rest_runs(
        make_tree: MakeTree) -> None:
    from mrss.supervision.spec import Group, OnExceeded

    tree = make_tree(worker("a"), worker("b"), worker("c"), intensity=1,
                     groups=(Group("infra", ("a", "b")),),
                     on_exceeded=OnExceeded.QUARANTINE, probation=math.inf)

    def kill_a_and_wait(incarnations: dict[str, int]) -> None:
        faults.kill(tree.sup, "a")
        wait_until(lambda: tree.all_running() and tree.incarnations() == incarnations,
                   timeout=15, message=f"incarnations {incarnations}")

    kill_a_and_wait({"a": 2, "b": 1, "c": 1})  # a alone
    kill_a_and_wait({"a": 3, "b": 2, "c": 1})  # a over its budget: the group restarts
    (group_restart,) = [e for e in tree.log.of("restart", "a") if e.detail.get("subtree")]
    assert group_restart.detail["subtree"] == "infra"
    assert group_restart.detail["group"] == ["a", "b"]
    kill_a_and_wait({"a": 4, "b": 2, "c": 1})  # fresh budgets after the group restart
    faults.kill(tree.sup, "a")  # over again: the group is over its window
    (give_up,) = tree.log.wait_for("give_up", "a", timeout=10)
    assert give_up.detail["subtree"] == "infra" and give_up.detail["members"] == ["a", "b"]
    assert give_up.detail["retry_in"] is None  # never retried
    wait_until(lambda: {c.id: c.state for c in tree.sup.tree().children} == {
        "a": "quarantined", "b": "quarantined", "c": "running"}, timeout=10)
    assert tree.sup.ping("c") and tree.incarnations()["c"] == 1 and tree.sup.outcome is None
    assert [e.reason for e in tree.log.of("exit", "b")][-1] == "shutdown: stopped by supervisor"
