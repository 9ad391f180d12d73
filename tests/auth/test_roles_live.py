"""Roles enforced by the components that execute the commands, through real processes:
`mrss supervise` of a project with users; commands sent on the bus and over MQTT with
the credentials of a commander, an operator, an observer, an expired user and a stranger.
The RCL, the root supervisor, the reasoner and the events manager refuse what a role
may not send (counted in their `Rejections`, logged, visible on the bus), and execute
what it may; the incident record names each command's author."""

from __future__ import annotations

import os
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from mrss.auth.roles import Role
from mrss.auth.sessions import mint
from mrss.auth.store import Identity, OperatorStore, store_path
from mrss.bus import Subscriber
from mrss.config.loader import load_file
from mrss.config.operator import read_operator
from mrss.incident.entries import IncidentKind
from mrss.incident.journal import incident_file, read_incident
from mrss.links.connect import project_broker_url
from mrss.messages import Command, Envelope, LogRecord, Percept, Rejections, RobotState
from mrss.testing import wait_until
from mrss.tui.mission import MissionChannel
from tests.auth.operators import project_with_users
from tests.faults.supervised import Supervised

pytestmark = pytest.mark.slow


class Watch:
    """What the test hears on the bus: robot states, log lines, refusal counts."""

    def __init__(self, sub: Subscriber) -> None:
        self.lock = threading.Lock()
        self.teleop: dict[str, bool] = {}
        self.logs: list[str] = []
        self.refused: dict[str, int] = {}  # component -> operator-command refusals
        sub.start(self.take)

    def take(self, env: Envelope) -> None:
        body = env.body
        with self.lock:
            if isinstance(body, RobotState) and "teleop" in body.attributes:
                self.teleop[body.robot] = bool(body.attributes["teleop"])
            elif isinstance(body, LogRecord):
                self.logs.append(body.message)
            elif isinstance(body, Rejections):
                self.refused[body.component] = sum(
                    n for what, n in body.counts.items() if what.startswith("operator command"))

    def logged(self, text: str) -> bool:
        with self.lock:
            return any(text in line for line in self.logs)


def test_each_component_refuses_what_the_senders_role_may_not_do(tmp_path: Path) -> None:
    projects = tmp_path / "projects"
    folder, otto_token = project_with_users(projects)
    store = OperatorStore.load(store_path(folder))
    cora = mint(store, Identity("cora", Role.COMMANDER))
    olga = mint(store, Identity("olga", Role.OBSERVER))
    expired = mint(store, Identity("otto", Role.OPERATOR), now=0)  # a session long over
    stranger = mint(OperatorStore.new(tmp_path / "other.json"),  # another store's key
                    Identity("cora", Role.COMMANDER))
    run_dir = tmp_path / "run"
    system = Supervised("tuimission", run_dir, projects=projects)
    watch = Watch(Subscriber(system.sub.endpoints, prefixes=["robot.", "log.",
                                                            "edge.rejections"],
                             name="roles-test"))
    try:
        system.wait_all_running()

        def send(credential: str, message: Command | Percept) -> None:
            system.pub.operator = credential
            system.pub.publish(message)

        # the RCL: an observer's teleop is refused there, an operator's is executed
        send(olga, Command("teleop", target="ugv1", args={"on": True}))
        wait_until(lambda: watch.logged("refused operator command from olga (observer): "
                                        "ctl.teleop ugv1: the observer role may not send teleop"),
                   timeout=30, message="the RCL's refusal of the observer's teleop")
        wait_until(lambda: watch.refused.get("rcl", 0) >= 1, timeout=30,
                   message="the refusal counted in the RCL's Rejections")
        assert watch.teleop.get("ugv1") is not True  # nothing executed
        for credential, who in ((expired, "the session of 'otto' expired"),
                                (stranger, "not signed by this project's store"),
                                ("", "no credential")):
            send(credential, Command("teleop", target="ugv1", args={"on": True}))
            wait_until(lambda who=who: watch.logged(who), timeout=30,
                       message=f"refused: {who}")
        send(otto_token, Command("teleop", target="ugv1", args={"on": True}))
        wait_until(lambda: watch.teleop.get("ugv1") is True, timeout=30,
                   message="the operator's teleop executed")
        wait_until(lambda: watch.refused.get("rcl", 0) >= 4, timeout=30,
                   message="four refusals counted by the RCL")
        # `mrss send` with an operator's personal token (MRSS_OPERATOR_TOKEN)
        sent = subprocess.run([sys.executable, "-m", "mrss", "send", "--run-dir",
                               str(run_dir), "teleop", "ugv1", "off"], capture_output=True,
                              text=True, timeout=60,
                              env={**os.environ, "MRSS_OPERATOR_TOKEN": otto_token})
        assert sent.returncode == 0, sent.stderr
        wait_until(lambda: watch.teleop.get("ugv1") is False, timeout=30,
                   message="mrss send's teleop off executed")

        # the root supervisor: an observer's stop is refused, the system keeps running
        send(olga, Command("stop", target="tuimission"))
        wait_until(lambda: watch.logged("olga (observer): ctl.stop tuimission: the "
                                        "observer role may not send stop"), timeout=30,
                   message="the root's refusal of the observer's stop")
        assert system.proc.poll() is None

        # the reasoner: an observer's percept is refused, an operator's reaches the agent
        send(olga, Percept("hold_all"))
        wait_until(lambda: watch.logged("olga (observer): percept add hold_all"),
                   timeout=30, message="the reasoner's refusal of the observer's percept")

        # the events manager: the commander-only exclusion zone over MQTT
        config = read_operator(load_file(folder / "project.toml").sections["operator"])
        channel = MissionChannel(config, lambda: project_broker_url(folder, run_dir))
        zone = {"zone": "x1", "shape": [[47.0, 15.0], [47.0, 15.01], [47.01, 15.01]]}
        spec = config.commands["exclusion"]
        channel.credential = otto_token
        answer = channel.send(spec, dict(zone))
        assert not answer.ok and "the operator role may not send it (it needs commander)" in \
            answer.text, answer
        channel.credential = cora
        answer = channel.send(spec, dict(zone))
        assert answer.ok, answer

        # every command in the incident record, with its author
        def authors() -> list[tuple[str, str]]:
            entries, _ = read_incident(incident_file(run_dir))
            return [(e.text, e.who) for e in entries if e.kind is IncidentKind.OPERATOR]
        wait_until(lambda: ("mrss/operator/exclusion accepted",
                            "cora via mqtt:mrss/operator/exclusion") in authors(),
                   timeout=30, message="the commander's zone in the record, by cora")
        record = authors()
        teleops = [who for text, who in record if text == "ctl.teleop ugv1 on=True"]
        assert teleops[0] == ("olga (observer): refused (the observer role may not send "
                              "teleop commands (only operator, commander))"), teleops
        assert teleops[-1] == "otto (operator)", teleops
        assert any("otto: refused (the session of 'otto' expired" in who for who in teleops)
    finally:
        system.close()
