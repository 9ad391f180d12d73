"""Several agents in one reasoner (the `agents` option): they talk with .send and
.broadcast, each perceives every percept, and each one's environment actions complete
back to it. In process (bus-agnostic `Reasoner`) and through a real reasoner process."""

from __future__ import annotations

import shutil
import tempfile
import textwrap
from collections.abc import Iterator
from pathlib import Path

import pytest

from mrss.actors.reasoner.agents import AgentSpec
from mrss.actors.reasoner.core import Reasoner
from mrss.actors.reasoner.service import ReasonerComponent
from mrss.bus import BusEndpoints, ProxyThread
from mrss.config.kinds import KINDS, ComponentKind
from mrss.errors import ConfigError
from mrss.messages import ActionRequest, ActionStatus, Percept
from mrss.runtime.component import ComponentContext
from mrss.supervision.children import ComponentStart, ProcessSettings
from mrss.supervision.process import ProcessSupervisor
from mrss.supervision.spec import ChildSpec, SupervisorSpec
from mrss.testing import wait_until
from tests.actors.reasoner.test_reasoner import env

LEADER = """
+fire(A)[source(percept)] <- .send(scout, achieve, look(A)).
+seen(A)[source(scout)] <- .broadcast(tell, done(A)); +finished(A).
"""
SCOUT = """
+!look(A)[source(leader)] <- fly(A); .send(leader, tell, seen(A)).
+fire(A)[source(percept)] <- +heard(A).
+done(A)[source(leader)] <- +acknowledged(A);
    .send(leader, askOne, finished(_), Answer); +answer(Answer).
"""


def _write(folder: Path) -> list[AgentSpec]:
    (folder / "leader.asl").write_text(textwrap.dedent(LEADER))
    (folder / "scout.asl").write_text(textwrap.dedent(SCOUT))
    return [AgentSpec("leader", "leader.asl"), AgentSpec("scout", "scout.asl")]


@pytest.fixture()
def society(tmp_path: Path) -> Iterator[tuple[Reasoner, list[ActionRequest]]]:
    requests: list[ActionRequest] = []
    reasoner = Reasoner(None, name="reasoner", agents=_write(tmp_path), base=tmp_path,
                        send_request=requests.append, send_control=lambda c: None,
                        lease=30.0, tick=0.05)
    reasoner.start()
    try:
        yield reasoner, requests
    finally:
        reasoner.stop()


def test_agents_of_one_reasoner_talk_perceive_and_act(
        society: tuple[Reasoner, list[ActionRequest]]) -> None:
    reasoner, requests = society
    leader, scout = reasoner.agents
    assert (leader.name, scout.name) == ("leader", "scout")
    reasoner.on_message(env(Percept(literal="fire(a1)"), src="events"))
    wait_until(lambda: scout.believes("heard(a1)"), message="the scout perceives too")
    req = wait_until(lambda: requests and requests[0], message="the scout's action")
    assert req.literal == "fly(a1)"
    assert not leader.believes("seen(a1)")  # the scout waits for its action
    reasoner.on_message(env(ActionStatus(uuid=req.uuid, state="succeeded", robot="")))
    wait_until(lambda: scout.believes("answer(finished(a1)[source(leader)])"),
               message="told, broadcast to, asked and answered")
    assert leader.believes("seen(a1)[source(scout)]")
    assert scout.believes("acknowledged(a1)")
    assert reasoner.mind_name(scout.snapshot()) == "reasoner.scout"


def test_the_agents_option_is_refused_with_the_entry_and_key(tmp_path: Path) -> None:
    _write(tmp_path)
    cases = [
        ([{"name": "leader", "fil": "leader.asl"}], "agent 1, fil: unknown key of an agent"),
        ([{"file": "leader.asl"}, {"name": "leader", "file": "scout.asl"}],
         "agent 2, name: two agents are named 'leader'"),
        ([{"name": "Leader", "file": "leader.asl"}], "agent 1, name: the agent's name "
                                                     "'Leader' must be an atom"),
        ([], "expected a non-empty list of agent tables"),
    ]
    for agents, message in cases:
        ctx = ComponentContext("reasoner", 1, tmp_path, tmp_path, options={"agents": agents})
        with pytest.raises(ConfigError, match="agents") as info:
            ReasonerComponent().start(ctx)
        assert message in str(info.value)
    (tmp_path / "bad.asl").write_text("+!g <- .send(x, tell).\n")
    ctx = ComponentContext("reasoner", 1, tmp_path, tmp_path,
                           options={"agents": [{"file": "bad.asl"}]})
    with pytest.raises(ConfigError, match=r"bad.asl:1:8: .send takes 3 to 4 arguments"):
        ReasonerComponent().start(ctx)


def test_a_reasoner_process_runs_its_agents_together(tmp_path: Path) -> None:
    (tmp_path / "ping.asl").write_text(
        "!start.\n+!start <- .all_names(L); .print(names(L)); .send(pong, achieve, ping).\n"
        "+pong[source(pong)] <- .print(got_pong).\n")
    (tmp_path / "pong.asl").write_text(
        "+!ping[source(S)] : ready <- .print(ping_from(S)); .send(S, tell, pong).\n")
    agents = [{"file": "ping.asl"}, {"file": "pong.asl", "beliefs": ["ready"]}]
    reasoner = ChildSpec("reasoner", ComponentStart(
        KINDS[ComponentKind.REASONER].target, {"agents": agents}, 20.0))
    sockets = Path(tempfile.mkdtemp(prefix="mrss-"))  # ipc paths must be short
    endpoints = BusEndpoints.ipc(sockets)
    settings = ProcessSettings(tmp_path, tmp_path, bus=endpoints.to_dict(),
                               heartbeat_interval=0.1, heartbeat_misses=50)
    with ProxyThread(endpoints):
        sup = ProcessSupervisor("root", SupervisorSpec(), [reasoner], settings)
        sup.start()
        try:
            assert sup.wait_started(30), "the reasoner did not start"
            log = tmp_path / "mrss.log"
            wait_until(lambda: log.is_file() and "[ping] got_pong" in log.read_text(),
                       timeout=30, message="ping got its pong")
        finally:
            sup.stop(timeout=30)
            shutil.rmtree(sockets, ignore_errors=True)
    text = log.read_text()
    assert "reasoner: [ping] names([ping,pong])" in text
    assert "reasoner: [pong] ping_from(ping)" in text


RING = """
+go[source(percept)] : starter & next(N) <- .send(N, achieve, ping(1)).
+!ping(K) : stop(K) <- +done; finished(K).
+!ping(K) : last_lap(L) & K >= L & next(N) <- +done; .send(N, achieve, ping(K + 1));
    finished(K).
+!ping(K) : next(N) <- .send(N, achieve, ping(K + 1)).
"""


def test_hundreds_of_agents_pass_a_token_round_and_idle_ones_are_not_stepped(
        tmp_path: Path) -> None:
    """A token goes three times round a ring of 300 agents of one reasoner, started by
    a percept; on its last lap every agent believes `done` and acts. A bystander with
    no plan for the percept takes a cycle or two for it and is then never stepped:
    a round costs its busy agents, not the number of agents."""
    n, laps = 300, 3
    hops = n * laps
    (tmp_path / "ring.asl").write_text(textwrap.dedent(RING))
    (tmp_path / "bystander.asl").write_text("")
    specs = [AgentSpec(f"a{i + 1}", "ring.asl",
                       [f"next(a{(i + 1) % n + 1})", f"stop({hops})",
                        f"last_lap({hops - n + 1})"] + (["starter"] if i == 0 else []))
             for i in range(n)]
    specs.append(AgentSpec("bystander", "bystander.asl"))
    requests: list[ActionRequest] = []
    reasoner = Reasoner(None, name="reasoner", agents=specs, base=tmp_path,
                        send_request=requests.append, send_control=lambda c: None,
                        lease=300.0, tick=0.05)
    reasoner.start()
    try:
        reasoner.on_message(env(Percept(literal="go"), src="events"))
        wait_until(lambda: len(requests) >= n, timeout=60,
                   message="every agent of the ring acts on its last lap")
    finally:
        reasoner.stop()
    *ring, bystander = reasoner.agents
    assert sorted(r.literal for r in requests) == sorted(
        f"finished({k})" for k in range(hops - n + 1, hops + 1))
    assert all(a.believes("done") for a in ring)
    assert bystander.cycle <= 3, f"the bystander was stepped {bystander.cycle} times"
