"""The wildfire project with every guard on, under `mrss supervise`: MAVLink signing
between the simulated UAV and its link, the world model's HTTP API on 0.0.0.0 with a
token, and the embedded broker with a password file. Before the mission, every edge is
fuzzed with seeded hostile traffic (tests/edge/edge_fuzz.py: bus frames, robot telemetry
over MQTT and MAVLink, HTTP, percepts for the parser, a replayed recording): no
traceback in any log, no component restart, no percept, telemetry, object or robot
command from a refused record, and every refusal counted on the bus. Then the mission
runs as usual: both robots report to the world model, an operator's area goal is flown,
and the hotspot found gets water."""

from __future__ import annotations

import random
import secrets
import shutil
import threading
from pathlib import Path

import pytest

from mrss.actors.broker.passwords import add_user
from mrss.actors.worldmodel.http import REFUSED
from mrss.api.testing import RunningProject
from mrss.bus import BusEndpoints, Subscriber
from mrss.edge.http_token import project_token
from mrss.links.connect import project_broker_url
from mrss.messages import (
    ActionRequest,
    Envelope,
    Heartbeat,
    Percept,
    Rejections,
    RobotData,
    SupEvent,
)
from mrss.testing import wait_until
from mrss.world.access import WorldModelClient, WorldModelRejected

from . import edge_fuzz

WILDFIRE = Path(__file__).resolve().parents[2] / "projects" / "wildfire"
AREA = {"goal": "a1", "priority": 2, "center": [-35.360567, 149.165237], "radius": 100}
PASSWORD = "mqtt-" + secrets.token_urlsafe(12)
SEED = 1515


class BusWatch:
    """What the fuzz test watches on the bus beside RunningProject's own view."""

    def __init__(self, run_dir: Path) -> None:
        self.lock = threading.Lock()
        self.seen: list[Envelope] = []
        self.sub = Subscriber(BusEndpoints.ipc(run_dir), prefixes=[
            "robot.", "sup.", "edge.rejections", "action.request", "rel.action", "percept",
            "rel.percept"])
        self.sub.start(self._keep)
        # Joined before anything raw is sent: on a direct bus it is a member, with a
        # socket of its own that the raw publisher must find (tests/bus/bus_helpers.py).
        assert self.sub.wait_connected(30), "the watch never joined the bus"

    def _keep(self, env: Envelope) -> None:
        with self.lock:
            self.seen.append(env)

    def bodies(self, kind: type) -> list[object]:
        with self.lock:
            return [e.body for e in self.seen if isinstance(e.body, kind)]

    def envelopes(self) -> list[Envelope]:
        with self.lock:
            return list(self.seen)

    def heard_probe(self, pid: int) -> bool:
        return any(b.component == "fuzz" and b.pid == pid  # type: ignore[attr-defined]
                   for b in self.bodies(Heartbeat))

    def report(self, component: str) -> Rejections | None:
        reports = [b for b in self.bodies(Rejections)
                   if isinstance(b, Rejections) and b.component == component]
        return reports[-1] if reports else None

    def refused(self, component: str) -> int:
        report = self.report(component)
        return report.total if report is not None else 0


def fuzz_every_edge(system: RunningProject, project: Path, tmp_path: Path) -> None:
    """Seeded hostile traffic on every edge, then what must (not) have come of it."""
    rng = random.Random(SEED)
    watch = BusWatch(system.run_dir)
    raw = edge_fuzz.RawBus(BusEndpoints.ipc(system.run_dir))
    try:
        raw.sync(watch.heard_probe)
        on_bus = edge_fuzz.fuzz_bus(raw, rng)
        raw.sync(watch.heard_probe)
        url = project_broker_url(project, system.run_dir)
        assert url is not None
        to_link, to_events = edge_fuzz.fuzz_mqtt(url, rng)
        unsigned, wrong = edge_fuzz.fuzz_mavlink(
            edge_fuzz.udp_ports(system.incarnations["rcl"][1]), rng)
        token = project_token(project)
        assert token is not None
        port = int(system.file("worldmodel.url").rsplit(":", 1)[1])
        statuses = edge_fuzz.fuzz_http(port, token, rng)
        assert {400, 401} <= set(statuses)
        replayed = edge_fuzz.fuzz_replay(system.run_dir, tmp_path, rng)
        # Every refusal counted, and the counts reach the bus: all was handled.
        # Every refusal counted, and the totals reach the bus: all was handled (totals:
        # a report names only the commonest kinds).
        expected = {"reasoner": on_bus.percepts + replayed.percepts,
                    "datalayer": on_bus.records + replayed.records,
                    "rcl": to_link + unsigned + wrong, "events": to_events,
                    "worldmodel": sum(s in REFUSED for s in statuses)}
        assert all(n > 0 for n in expected.values()), expected
        try:
            wait_until(lambda: all(watch.refused(c) >= n for c, n in expected.items()), 60,
                       message="every refusal counted")
        except AssertionError:
            counted = [(c, watch.refused(c), n) for c, n in expected.items()]
            raise AssertionError(f"(component, refusals counted, sent): {counted}\n"
                                 f"{system.log()}") from None
        rcl = watch.report("rcl")
        assert rcl is not None
        kinds = " ".join(rcl.counts)
        for kind in ("telemetry record from ugv1: ", ": unsigned", ": bad signature"):
            assert kind in kinds, rcl.counts  # the link's checks and the signing's
        assert ": replayed" not in kinds, rcl.counts
        for component, what in (("reasoner", "percept from "),
                                ("datalayer", "robot data from "), ("events", "event from "),
                                ("worldmodel", "HTTP request from ")):
            report = watch.report(component)  # (the replay is refused at the bus's door)
            assert report is not None and all(
                k.startswith((what, "bus message from recorded: replayed, not live"))
                for k in report.counts), report
        # ... and nothing came of it
        log = system.log(tail=10_000_000)
        assert "Traceback" not in log, log[log.index("Traceback") - 2000:][:6000]
        assert not [b for b in watch.bodies(SupEvent) if isinstance(b, SupEvent)
                    and b.event in ("restart", "exit", "hang", "give_up")]
        assert all(inc == 1 for name, (inc, _) in system.incarnations.items()
                   if name != "fuzz"), system.incarnations
        assert system.statuses() == [] and watch.bodies(ActionRequest) == []
        made = [e.body.literal for e in watch.envelopes() if isinstance(e.body, Percept)
                and e.src not in (edge_fuzz.SRC, "recorded")]  # by the system itself
        assert not [p for p in made if p.startswith(("hotspot_detected", "fz"))], made
        from_links = [e.body.data for e in watch.envelopes() if isinstance(e.body, RobotData)
                      and e.src == "rcl"]
        assert from_links, "no telemetry from the links"
        assert not [d for d in from_links if d.get("lat") == edge_fuzz.FORGED_LAT
                    or d.get("id") in edge_fuzz.FORGED_IDS or d.get("type") == "hotspot"]
        world = WorldModelClient(run_dir=system.run_dir, token=token, timeout=5)
        assert world.objects("hotspot") == []
    finally:
        raw.close()
        watch.sub.close()


def secured_copy(root: Path) -> Path:
    folder = root / "projects" / "wildfire_secured"
    shutil.copytree(WILDFIRE, folder, ignore=shutil.ignore_patterns("__pycache__",
                                                                     "procedures"))
    (folder / "keys").mkdir()
    uavs = ("uav1", "uav2", "uav3")  # the fleet's UAVs: each signs with its own key
    for uav in uavs:
        (folder / "keys" / f"{uav}.key").write_text(secrets.token_hex(32) + "\n")
    (folder / "secrets").mkdir()
    (folder / "secrets" / "worldmodel.token").write_text(secrets.token_urlsafe(32) + "\n")
    add_user(folder / "secrets" / "mqtt.passwd", "ops", PASSWORD)
    for path in (*folder.glob("keys/*"), *folder.glob("secrets/*")):
        path.chmod(0o600)
    toml = (folder / "project.toml").read_text()
    signing = [(f'id = "{uav}"\n', f'id = "{uav}"\nsigning_key = "keys/{uav}.key"\n')
               for uav in uavs] + \
        [(f'[components.rcl.robots.{uav}]\nlink = "mavlink"',
          f'[components.rcl.robots.{uav}]\nsigning_key = "keys/{uav}.key"\nlink = "mavlink"')
         for uav in uavs]
    for old, new in (
        *signing,
        ('[worldmodel]\n', '[worldmodel]\nhttp_host = "0.0.0.0"\n'
                           'token_file = "secrets/worldmodel.token"\n'),
        ('[events]\n', '[broker]\nusername = "ops"\npassword_env = "MRSS_TEST_MQTT_PASSWORD"\n'
                       '[broker.embedded]\npassword_file = "secrets/mqtt.passwd"\n\n[events]\n'),
    ):
        assert toml.count(old) == 1, old
        toml = toml.replace(old, new)
    (folder / "project.toml").write_text(toml)
    return folder


@pytest.mark.slow
def test_the_wildfire_mission_runs_with_every_guard_on(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MRSS_TEST_MQTT_PASSWORD", PASSWORD)   # for this process's publish
    project = secured_copy(tmp_path)
    with RunningProject(project, tmp_path / "run", env={"MRSS_SIM_SPEEDUP": "20"}) as system:
        system.wait_ready(timeout=60)
        # the data layer stores telemetry; the world model answers only with the token
        system.wait_for(lambda: (system.world("uav1") or {}).get("position"), 30,
                        "UAV telemetry (signed MAVLink) in the world model")
        system.wait_for(lambda: (system.world("ugv1") or {}).get("position"), 30,
                        "UGV telemetry (MQTT with the project's login) in the world model")
        assert system.file("worldmodel.url").startswith("http://0.0.0.0:")
        with pytest.raises(WorldModelRejected, match="HTTP 401"):
            WorldModelClient(run_dir=system.run_dir, timeout=5).get("uav1")
        fuzz_every_edge(system, project, tmp_path)
        refusal_lines = system.log(tail=10_000_000).count("refused MAVLink message from")
        # the operator's goal: MQTT with the login -> events -> world model (token) -> cover
        system.publish("mrss/ui/area", AREA)
        system.wait_for(lambda: system.statuses("uav1", "succeeded"), 90,
                        "the area covered (signed commands obeyed)")
        system.wait_for(lambda: system.statuses("ugv1", "succeeded"), 90,
                        "water on the hotspot found (the UGV over MQTT with the login)")
        assert not system.statuses(state="failed"), system.log()
        # the fuzz's refusals were logged (at a limited rate), and none came after them
        # (a summary of those held back may: it says "refused N more")
        assert system.log(tail=10_000_000).count("refused MAVLink message from") == refusal_lines
        assert refusal_lines >= 1
        assert system.interrupt() == 0, system.log()
