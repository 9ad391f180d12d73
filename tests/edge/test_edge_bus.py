"""The edge components on the real bus: events -> percepts, data layer <-> world model.

A ZeroMQ proxy runs on a thread of the test process; each component gets the context a
supervisor would give it (name, folders, configuration, its own Publisher, endpoints).
"""

from __future__ import annotations

import itertools
import json
import shutil
import tempfile
import threading
import urllib.request
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from mrss.actors.datalayer.service import DataLayerComponent
from mrss.actors.events.service import ExternalEventsManager
from mrss.actors.worldmodel.service import URL_FILE, WorldModelComponent
from mrss.bus import BusEndpoints, ProxyThread, Publisher, Subscriber
from mrss.config.broker import BROKER_URL_FILE
from mrss.edge.mqtt_client import MqttClient, MqttSettings
from mrss.messages import DataReply, DataRequest, Envelope, Percept, RobotData
from mrss.runtime.busport import ZmqBusPort
from mrss.runtime.component import ComponentContext
from mrss.runtime.datalayer_client import DataLayerClient, DataLayerError, DataLayerUnavailable
from mrss.testing import BrokerInfo, wait_until
from tests.edge.fixture_project import PROJECT_FIXTURE

from .termcheck import read_literal

# The fixture's project.toml gives [events], [datalayer] and [worldmodel]; the broker
# URL comes the way a deployment's would: from [components.<id>] free keys (ctx.options).


def context(name: str, run_dir: Path, endpoints: BusEndpoints,
            options: dict[str, Any] | None = None) -> ComponentContext:
    """The context the supervisor hands a component."""
    return ComponentContext(name=name, incarnation=1, project_dir=PROJECT_FIXTURE,
                            run_dir=run_dir, bus=endpoints.to_dict(), options=options or {})


class PerceptLog:
    """A Subscriber on `percept`, collecting literals."""

    def __init__(self, endpoints: BusEndpoints) -> None:
        self.literals: list[str] = []
        self._lock = threading.Lock()
        self.sub = Subscriber(endpoints, prefixes=["percept"])
        self.sub.start(self._on)
        assert self.sub.wait_connected(10)

    def _on(self, env: Envelope) -> None:
        if isinstance(env.body, Percept):
            with self._lock:
                self.literals.append(env.body.literal)

    def snapshot(self) -> list[str]:
        with self._lock:
            return list(self.literals)


@dataclass
class Edge:
    endpoints: BusEndpoints
    run_dir: Path
    world: Any
    data: Any
    events: Any
    percepts: PerceptLog
    client: DataLayerClient
    broker: BrokerInfo


@pytest.fixture()
def edge(mqtt_broker: BrokerInfo) -> Iterator[Edge]:
    run_dir = Path(tempfile.mkdtemp(prefix="mrss-edge-"))
    endpoints = BusEndpoints.ipc(run_dir)
    (run_dir / BROKER_URL_FILE).write_text(mqtt_broker.url)  # as the broker component does
    stoppers: list[Any] = []
    try:
        with ProxyThread(endpoints):
            percepts = PerceptLog(endpoints)
            stoppers.append(percepts.sub)
            contexts = []
            started = []
            for name, component in (("worldmodel", WorldModelComponent()),
                                    ("datalayer", DataLayerComponent()),
                                    ("events", ExternalEventsManager())):
                ctx = context(name, run_dir, endpoints)
                component.start(ctx)
                stoppers.append(component)
                contexts.append(ctx)
                started.append(component)
            world, data, events = started
            caller = context("reasoner", run_dir, endpoints)
            contexts.append(caller)
            port = ZmqBusPort(endpoints, caller.publisher, "reasoner")
            stoppers.append(port)
            client = DataLayerClient(port)
            # pub/sub needs its subscriptions in place: wait until a round trip works
            wait_until(lambda: client.request("ping", timeout=0.5).ok, timeout=15,
                       message="data layer answering")
            wait_until(lambda: client.request("ground", ["lake"], timeout=0.5).ok,
                       timeout=15, message="world model answering")
            yield Edge(endpoints, run_dir, world, data, events, percepts, client,
                       mqtt_broker)
    finally:
        for each in reversed(stoppers):
            each.stop() if hasattr(each, "stop") else each.close()
        for ctx in contexts:
            ctx.publisher.close()
        shutil.rmtree(run_dir, ignore_errors=True)


def test_grounding_goes_through_data_layer_to_world_model(edge: Edge) -> None:
    lake = edge.client.call("ground", ["lake"], timeout=5)
    assert lake["kind"] == "water_source" and lake["position"]["lat"] == 43.62
    assert [o["id"] for o in edge.client.call("objects", ["base"], timeout=5)] == ["base1"]


def test_error_and_timeout_replies_raise_clear_errors_in_the_caller(edge: Edge) -> None:
    """A function that failed because its own dependency was away (or ran out of time)
    is DataLayerUnavailable in the caller, as no reply at all is: worth another try
    (chaos, 15 faults seed 5: the RCL's refinement of a cover failed for good when the
    world model behind area_polygon did not answer). Other failures are not."""
    for function, args, reason in (("ground", ["atlantis"], "no object 'atlantis'"),
                                   ("explode", [], "the external service is down")):
        with pytest.raises(DataLayerError, match=reason) as plain:
            edge.client.call(function, args, timeout=5)
        assert not isinstance(plain.value, DataLayerUnavailable)
    with pytest.raises(DataLayerUnavailable, match="world model restarting"):
        edge.client.call("world_away", timeout=5)
    with pytest.raises(DataLayerUnavailable, match="hang timed out after 0.5s"):
        edge.client.call("hang", timeout=5)
    reply = edge.client.request("add", [1, 2], timeout=5)
    assert reply.ok and reply.result == 3


def test_client_times_out_when_nobody_answers(edge: Edge) -> None:
    publisher = Publisher(edge.endpoints, src="lonely")
    port = ZmqBusPort(edge.endpoints, publisher, "lonely")
    lonely = DataLayerClient(port, request_topic="dl.request.nobody",
                             reply_topic="dl.reply.nobody")
    try:
        reply = lonely.request("ping", timeout=0.3)
        assert not reply.ok and "no reply to 'ping' within 0.3s" in reply.error
        with pytest.raises(DataLayerError, match="no reply"):
            lonely.call("ping", timeout=0.3)
    finally:
        port.close()
        publisher.close()


def test_concurrent_requests_get_their_own_replies(edge: Edge) -> None:
    with ThreadPoolExecutor(max_workers=8) as pool:
        results = list(pool.map(lambda i: edge.client.call("add", [i, 1000], timeout=10),
                                range(60)))
    assert results == [i + 1000 for i in range(60)]


def test_telemetry_reaches_the_world_model(edge: Edge) -> None:
    pub = Publisher(edge.endpoints, src="rcl")
    try:
        assert pub.wait_connected(10)

        def robot_seen() -> bool:
            pub.publish(RobotData(robot="uav1", data={"lat": 43.61, "lon": 1.45,
                                                      "battery": 80}))
            return edge.client.request("ground", ["uav1"], timeout=0.5).ok
        wait_until(robot_seen, timeout=15, message="telemetry in the world model")
        uav = edge.client.call("ground", ["uav1"], timeout=5)
        assert uav["attributes"]["battery"] == 80 and uav["position"]["lon"] == 1.45
    finally:
        pub.close()


def post_object(url: str, obj: dict[str, Any]) -> int:
    req = urllib.request.Request(url + "/objects", data=json.dumps(obj).encode(),
                                 method="POST", headers={"Content-Type": "application/json"})
    with urllib.request.urlopen(req, timeout=5) as resp:
        status: int = resp.status
        return status


def test_http_insert_fires_a_rule_whose_percept_reaches_the_bus(edge: Edge) -> None:
    url = (edge.run_dir / URL_FILE).read_text().strip()
    assert url.startswith("http://127.0.0.1:")
    # h_wet is 100 m from the seeded lake: no percept; h_dry is 9 km away: a percept.
    assert post_object(url, {"id": "h_wet", "kind": "hotspot",
                             "position": {"lat": 43.6209, "lon": 1.44}}) == 201
    assert post_object(url, {"id": "h_dry", "kind": "hotspot",
                             "position": {"lat": 43.70, "lon": 1.44}}) == 201
    wait_until(lambda: "hotspot_detected(h_dry,43.7,1.44)" in edge.percepts.snapshot(),
               timeout=10, message="hotspot percept on the bus")
    assert not any("h_wet" in p for p in edge.percepts.snapshot())
    assert edge.client.call("ground", ["h_wet"], timeout=5)["kind"] == "hotspot"


def test_mqtt_event_becomes_a_percept_on_the_bus(edge: Edge) -> None:
    sender = MqttClient(MqttSettings.from_url(edge.broker.url))
    sender.start()
    try:
        assert sender.wait_connected(10)
        sender.publish("fixture/area", b'{"area": "zone \\"7\\"", "priority": 2}')
        sender.publish("fixture/area", b"\xff garbage")
        wait_until(edge.percepts.snapshot, timeout=10, message="percept")
        assert read_literal(edge.percepts.snapshot()[0]) == (
            "area_goal_received", ['zone "7"', 2], [])
        wait_until(lambda: edge.events.stats()["bad_payloads"] == 1, timeout=10,
                   message="bad payload counted")
        assert len(edge.percepts.snapshot()) == 1
    finally:
        sender.stop()


def test_writes_sent_without_waiting_are_applied_in_order_and_failures_counted(
        edge: Edge) -> None:
    world = edge.data._world  # the data layer's BusWorldModel, as its telemetry path uses
    sent: list[DataRequest] = []
    replies: dict[str, DataReply] = {}

    def seen(env: Envelope) -> None:
        if isinstance(env.body, DataRequest) and env.body.function == "wm.upsert_many":
            sent.append(env.body)
        elif isinstance(env.body, DataReply):
            replies[env.body.request_id] = env.body

    sub = Subscriber(edge.endpoints, prefixes=["dl.request.wm", "dl.reply.wm"])
    sub.start(seen)
    try:
        assert sub.wait_connected(10)
        world.upsert_nowait({"id": "", "kind": "robot"})  # refused by the world model
        for n in range(20):
            world.upsert_nowait({"id": "ugv9", "kind": "robot", "attributes": {"n": n}})
        wait_until(lambda: sum(len(r.args[0]) for r in sent) == 21
                   and all(r.request_id in replies for r in sent), timeout=15,
                   message="every batch of writes answered")
        assert world.batches == len(sent)
        results = [each for r in sent for each in replies[r.request_id].result]
        assert "error" in results[0] and all(replies[r.request_id].ok for r in sent)
        assert results[1] == {"op": "insert"}  # the op only: nobody waits
        assert results[2:] == [{"op": "update"}] * 19
        wait_until(lambda: world.client.failed_sends == 1, timeout=5,
                   message="the refused write counted")
        assert edge.client.call("ground", ["ugv9"], timeout=5)["attributes"]["n"] == 19
        assert world.client.unmatched_replies == 0
    finally:
        sub.close()


class _WriteTraffic:
    """Requests for `wm.upsert_many` and their replies, in the order the bus carried them."""

    def __init__(self, endpoints: BusEndpoints) -> None:
        self.events: list[tuple[str, str, int]] = []  # ("request" | "reply", id, objects)
        self._lock = threading.Lock()
        self.sub = Subscriber(endpoints, prefixes=["dl.request.wm", "dl.reply.wm"])
        self.sub.start(self._on)
        assert self.sub.wait_connected(10)

    def _on(self, env: Envelope) -> None:
        body = env.body
        with self._lock:
            if isinstance(body, DataRequest) and body.function == "wm.upsert_many":
                self.events.append(("request", body.request_id, len(body.args[0])))
            elif isinstance(body, DataReply):
                self.events.append(("reply", body.request_id, 0))

    def snapshot(self) -> list[tuple[str, str, int]]:
        with self._lock:
            return list(self.events)

    def sent(self) -> int:
        return sum(n for kind, _, n in self.snapshot() if kind == "request")


def test_a_batch_of_writes_waits_for_the_answer_to_the_last(edge: Edge) -> None:
    world = edge.data._world
    traffic = _WriteTraffic(edge.endpoints)
    try:
        for n in range(300):
            world.upsert_nowait({"id": f"ugv{n % 7}", "kind": "robot", "attributes": {"n": n}})
        wait_until(lambda: traffic.sent() == 300, timeout=15, message="every write sent")
        events = traffic.snapshot()
        requests = [rid for kind, rid, _ in events if kind == "request"]
        wait_until(lambda: {rid for kind, rid, _ in traffic.snapshot() if kind == "reply"}
                   >= set(requests), timeout=15, message="every batch answered")
        for first, second in itertools.pairwise(requests):  # one batch in flight at a time
            assert events.index(("reply", first, 0)) < events.index(("request", second,
                                                                     _size(events, second)))
        assert world.paced
    finally:
        traffic.sub.close()


def test_writes_go_on_without_waiting_while_the_world_model_does_not_answer(
        edge: Edge) -> None:
    world = edge.data._world
    traffic = _WriteTraffic(edge.endpoints)
    try:
        edge.world.stop()  # nobody answers now
        world.upsert_nowait({"id": "ugv1", "kind": "robot", "attributes": {"n": 0}})
        wait_until(lambda: not world.paced, timeout=15, message="pacing given up")
        for n in range(1, 6):
            world.upsert_nowait({"id": "ugv1", "kind": "robot", "attributes": {"n": n}})
            wait_until(lambda n=n: traffic.sent() == n + 1, timeout=15,
                       message=f"write {n} sent without an answer to the last")
        assert not world.paced and all(kind == "request" for kind, _, _ in traffic.snapshot())
    finally:
        traffic.sub.close()


def _size(events: list[tuple[str, str, int]], request_id: str) -> int:
    return next(n for kind, rid, n in events if kind == "request" and rid == request_id)


def test_a_call_is_not_held_up_by_writes_that_keep_coming(edge: Edge) -> None:
    world = edge.data._world
    stop = threading.Event()

    def flood() -> None:
        n = 0
        while not stop.wait(0.005):  # ~2,000 writes a second, as a big fleet's telemetry
            for _ in range(10):
                world.upsert_nowait({"id": f"ugv{n % 9}", "kind": "robot",
                                     "attributes": {"n": n}})
                n += 1

    writer = threading.Thread(target=flood)
    writer.start()
    try:
        for _ in range(5):  # each waits for the writes queued before it, not for later ones
            assert edge.client.call("ground", ["lake"], timeout=10)["kind"] == "water_source"
    finally:
        stop.set()
        writer.join()
