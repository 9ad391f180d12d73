"""The RCL as a real component process under the real root supervisor, on a real bus proxy
process: SIGKILL it while five actions run; the supervisor restarts it (incarnation 2),
and each action runs again from its journaled progress, the reasoner side (here the
test) hearing about every one."""

from __future__ import annotations

import json
import sqlite3
from pathlib import Path
from typing import Any

import pytest

from mrss.bus import BusEndpoints, ReliableSender, Subscriber
from mrss.messages import ActionRequest, ActionStatus, Envelope
from mrss.supervision import ProcessSupervisor
from mrss.supervision.faults import kill
from mrss.testing import wait_until
from tests.actors.rcl.processes import Procs, rcl_child, root

PROJECT = Path(__file__).parent / "rcl_project"
ROBOTS = [f"ugv{i}" for i in range(1, 6)]


def _supervisor(run_dir: Path, endpoints: BusEndpoints) -> ProcessSupervisor:
    options: dict[str, Any] = {"robots": {r: {"leg": 0.05} for r in ROBOTS}}
    return root(PROJECT, run_dir, endpoints, [rcl_child(options)])


def _progress(journal: Path, uuid: str) -> int:
    with sqlite3.connect(str(journal)) as db:
        row = db.execute("SELECT progress FROM actions WHERE uuid=?", (uuid,)).fetchone()
    return int(json.loads(row[0]).get("waypoint", 0)) if row else 0


@pytest.mark.slow
def test_sigkilled_rcl_resumes_or_fails_every_running_action(
    procs: Procs, run_dir: Path,
) -> None:
    endpoints = BusEndpoints.ipc(run_dir)
    procs.start("mrss.bus.proxy", "--run-dir", str(run_dir))
    seen: list[Envelope] = []
    sub = Subscriber(endpoints, prefixes=["action.status"])
    sub.start(seen.append)
    tx = ReliableSender(endpoints, src="reasoner", inc=1, channel="action")
    sup = _supervisor(run_dir, endpoints)
    try:
        assert sub.wait_connected(5)
        sup.start()
        assert sup.wait_started(30), "the RCL component did not start"
        uuids = [f"act-{r}" for r in ROBOTS]
        for uuid, robot in zip(uuids, ROBOTS, strict=True):
            tx.send(ActionRequest(uuid=uuid, name="patrol", args=[robot, "g", list(range(40))]))
        journal = run_dir / "rcl-journal.sqlite3"
        wait_until(lambda: all(_progress(journal, u) >= 3 for u in uuids), timeout=20,
                   message="every action past waypoint 3")

        kill(sup, "rcl")  # SIGKILL; the root supervisor restarts it
        kept = {u: _progress(journal, u) for u in uuids}

        def after_restart(uuid: str) -> list[ActionStatus]:
            return [e.body for e in list(seen) if e.inc == 2 and
                    isinstance(e.body, ActionStatus) and e.body.uuid == uuid]

        for uuid in uuids:
            wait_until(lambda u=uuid: bool(after_restart(u)), timeout=20,  # type: ignore[misc]
                       message=f"{uuid} heard of after the restart")
            first = after_restart(uuid)[0]
            assert first.state == "running" and "RCL restart" in first.reason
            assert int(first.progress["waypoint"]) >= kept[uuid]  # type: ignore[arg-type]
        for uuid in uuids:
            wait_until(lambda u=uuid: after_restart(u)[-1].state == "succeeded",  # type: ignore[misc]
                       timeout=30, message=f"{uuid} succeeded after the restart")
        assert {c.id: c.incarnation for c in sup.tree().children} == {"rcl": 2}
    finally:
        sup.stop(timeout=30)
        tx.close()
        sub.close()
