"""Records a running system into a campaign history: bus, operator replies, probes, journal, log.

- The bus: `action.*` (requests on the reliable channel too; the RCL's allocations of
  tasks addressed to a role, `TaskAllocation` on `action.allocation`), `sup.*`,
  `robot.*`, `percept`, `log.*`, `mind.*`, stamped on arrival. To keep the file small, robot
  telemetry is kept only when it carries a mode (`teleop` or `mode`), and of the
  heartbeats only the first of each incarnation.
- The operator's replies: MQTT messages on the project's reply topics (reconnecting to
  the broker named in `broker.url` whenever it restarts).
- Probes: the supervision tree (`ctl.tree`), a mind snapshot (`ctl.mind`) and the open
  actions of the RCL journal, asked for at one moment.
- At the end: the whole RCL journal (SQLite, opened read-only; with what its compaction
  dropped: how many actions, and the watermark before which none is left) and the run's
  log lines (`mrss.log` with its rotated files, oldest first) of the reasoner and RCL
  (and every warning or error), with their creation times. A journal or log that cannot be read is
  recorded with its error, never skipped quietly: the checker calls such a history
  incomplete.

Wall-clock times (journal, log) are moved onto the campaign's time line by its start.
"""

from __future__ import annotations

import json
import re
import sqlite3
import threading
import time
from collections.abc import Iterable
from dataclasses import asdict
from datetime import datetime
from pathlib import Path
from typing import Any

from paho.mqtt import client as mqtt

from mrss.bus import BusEndpoints, Publisher, Stale, Subscriber
from mrss.chaos.history import HistoryWriter, OpenAction
from mrss.chaos.views import TERMINAL
from mrss.links.mqtt_url import new_client, parse_broker_url
from mrss.logfile import read_history
from mrss.logs import log_file
from mrss.messages import (
    ActionStatus,
    AllocationState,
    Command,
    Envelope,
    Heartbeat,
    MindSnapshot,
    RobotData,
    SupEvent,
    SupEventKind,
    TaskAllocation,
)

PREFIXES = ["action.", "rel.action.msg", "sup.", "robot.", "percept", "log.", "mind."]
MODE_KEYS = ("teleop", "mode")
LOG_LINE = re.compile(r"^(\d{4}-\d\d-\d\d \d\d:\d\d:\d\d),(\d{3}) (\S+)\[(\d+)\] (\w+) (.*)$")
KEPT_LEVELS = ("WARNING", "ERROR", "CRITICAL")


class Recorder:
    """Listens to one running system and writes what it sees to a HistoryWriter."""

    def __init__(self, run_dir: Path, writer: HistoryWriter, journal: Path,
                 reply_topics: Iterable[str] = ()) -> None:
        self.run_dir, self.writer, self.journal_path = run_dir, writer, journal
        self.t0, self.wall0 = time.monotonic(), time.time()
        self._lock = threading.Lock()
        self._pids: dict[str, int] = {}
        self._incs: set[tuple[str, int]] = set()
        self._replies: dict[str, Envelope] = {}
        self._answer = threading.Condition(self._lock)
        self._answered: set[str] = set()  # ids of operator steps a reply named
        # role task -> (its robot, state, when it began running on that robot: now())
        self._tasks: dict[str, tuple[str, str, float]] = {}
        endpoints = BusEndpoints.ipc(run_dir)
        self._pub = Publisher(endpoints, src="chaos")
        self._sub = Subscriber(endpoints, prefixes=PREFIXES, name="chaos-recorder",
                               stale=Stale.KEEP)  # the history judges stale messages itself
        self._sub.start(self._on_bus)
        self._mqtt = ReplyListener(run_dir, list(reply_topics), self._on_reply)

    def now(self) -> float:
        return round(time.monotonic() - self.t0, 3)

    def since_start(self, wall: float) -> float:
        return round(wall - self.wall0, 3)

    def close(self) -> None:
        self._mqtt.close()
        self._sub.close()
        self._pub.close()

    # -- the bus -----------------------------------------------------------------------------
    def _on_bus(self, env: Envelope) -> None:
        body = env.body
        if isinstance(body, RobotData) and not any(k in body.data for k in MODE_KEYS):
            return
        with self._lock:
            if isinstance(body, Heartbeat):
                self._pids[body.component] = body.pid
                if (env.src, env.inc) in self._incs:
                    return
                self._incs.add((env.src, env.inc))
            elif isinstance(body, SupEvent):
                if body.event is SupEventKind.START and body.pid:
                    self._pids[body.child] = body.pid
                elif body.event is SupEventKind.TREE:
                    self._learn_tree(body.detail.get("tree"))
                self._replies[f"sup.{body.event}"] = env
                self._answer.notify_all()
            elif isinstance(body, MindSnapshot):
                self._replies["mind"] = env
                self._answer.notify_all()
            elif isinstance(body, TaskAllocation | ActionStatus):
                self._follow_task(body)
        self.writer.write("bus", t=self.now(), topic=env.topic, src=env.src, inc=env.inc,
                          kind=env.kind, body=asdict(body))  # type: ignore[call-overload]

    def _learn_tree(self, tree: Any) -> None:
        if not isinstance(tree, dict):
            return
        for child in tree.get("children") or []:
            if isinstance(child, dict):
                if child.get("pid") and child.get("state") == "running":
                    self._pids[str(child.get("id"))] = int(child["pid"])
                self._learn_tree(child)

    def _follow_task(self, body: TaskAllocation | ActionStatus) -> None:
        """Which robot each task addressed to a role is on, and in what state (under the
        lock): an award puts it there, a status on no robot or a terminal one ends it."""
        if isinstance(body, TaskAllocation):
            if body.state is AllocationState.AWARDED:
                self._tasks[body.uuid] = (body.robot, "awarded", 0.0)
        elif body.uuid in self._tasks:
            if body.state.value in TERMINAL or not body.robot:
                del self._tasks[body.uuid]
                return
            robot, state, began = self._tasks[body.uuid]
            if (robot, state) != (body.robot, "running") and body.state.value == "running":
                began = self.now()  # it (re)starts on this robot
            self._tasks[body.uuid] = (body.robot, body.state.value, began)

    def tasks_running_on(self, robot: str, since: float = 0.0) -> list[str]:
        """The tasks addressed to a role that `robot` runs now, as the bus told; with
        `since`, only those that began running on it at or after that time (now())."""
        with self._lock:
            return sorted(u for u, (r, state, began) in self._tasks.items()
                          if r == robot and state == "running" and began >= since)

    def pid_of(self, component: str) -> int | None:
        with self._lock:
            return self._pids.get(component)

    def _ask(self, command: Command, answer: str, timeout: float) -> Envelope | None:
        with self._lock:
            before = self._replies.get(answer)
        self._pub.publish(command)
        deadline = time.monotonic() + timeout
        with self._lock:
            while self._replies.get(answer) is before:
                left = deadline - time.monotonic()
                if left <= 0:
                    return None
                self._answer.wait(left)
            return self._replies[answer]

    def tree(self, timeout: float = 3.0) -> dict[str, Any] | None:
        """The supervision tree, fresh from the root (None if it did not answer)."""
        env = self._ask(Command(command="tree"), "sup.tree", timeout)
        tree = env.body.detail.get("tree") if env and isinstance(env.body, SupEvent) else None
        return tree if isinstance(tree, dict) else None

    def mind(self, timeout: float = 3.0) -> dict[str, Any] | None:
        env = self._ask(Command(command="mind"), "mind", timeout)
        return asdict(env.body) if env and isinstance(env.body, MindSnapshot) else None

    # -- the operator's side -------------------------------------------------------------------
    def _on_reply(self, topic: str, payload: bytes) -> None:
        text = payload.decode("utf-8", errors="replace")
        self.writer.write("reply", t=self.now(), topic=topic, payload=text)
        try:
            answer = json.loads(text)
        except ValueError:
            return
        if isinstance(answer, dict) and isinstance(answer.get("id"), str):
            with self._answer:
                self._answered.add(answer["id"])
                self._answer.notify_all()

    @property
    def answers_expected(self) -> bool:
        """Whether the project answers the operator (it declares reply topics)."""
        return bool(self._mqtt.topics)

    def wait_answer(self, event_id: str, timeout: float) -> bool:
        """Whether a reply naming `event_id` arrives within `timeout` s (or came already)."""
        with self._answer:
            return self._answer.wait_for(lambda: event_id in self._answered, timeout)

    # -- probes and the end ----------------------------------------------------------------------
    def probe(self, system_running: bool) -> dict[str, Any]:
        """Ask for the tree, the mind and the journal's open actions; write a probe record."""
        if system_running:
            tree, mind, opened = self.tree(), self.mind(), self.open_actions()
        else:
            tree, mind, opened = None, None, None
        record = {"t": self.now(), "mind": mind, "tree": tree,
                  "open_actions": None if opened is None else [asdict(a) for a in opened],
                  "system_running": system_running}
        self.writer.write("probe", **record)
        return record

    def _db(self) -> sqlite3.Connection:
        return sqlite3.connect(f"file:{self.journal_path}?mode=ro", uri=True, timeout=5)

    def open_actions(self) -> list[OpenAction] | None:
        marks = ",".join("?" * len(TERMINAL))
        try:
            with self._db() as db:
                rows = db.execute("SELECT uuid, state, robot, goal, requester, requester_inc "
                                  f"FROM actions WHERE state NOT IN ({marks})",
                                  TERMINAL).fetchall()
        except sqlite3.Error:
            return None
        return [OpenAction(*row) for row in rows]

    def record_journal(self) -> None:
        """The whole journal as one record (an `error` if it cannot be read)."""
        record: dict[str, Any] = {"t": self.now(), "actions": [], "transitions": [],
                                  "teleop": {}}
        try:
            with self._db() as db:
                record["actions"] = [
                    {"uuid": u, "name": n, "robot": r, "goal": g, "state": s, "reason": why,
                     "requester": q, "requester_inc": qi, "created": self.since_start(c)}
                    for u, n, r, g, s, why, q, qi, c in db.execute(
                        "SELECT uuid, name, robot, goal, state, reason, requester, "
                        "requester_inc, created FROM actions ORDER BY created")]
                record["transitions"] = [
                    {"seq": seq, "uuid": u, "state": s, "reason": why,
                     "t": self.since_start(ts)}
                    for seq, u, s, why, ts in db.execute(
                        "SELECT seq, uuid, state, reason, ts FROM transitions ORDER BY seq")]
                record["teleop"] = {r: bool(on) for r, on in db.execute(
                    "SELECT robot, teleop FROM robots")}
                if db.execute("SELECT 1 FROM sqlite_master WHERE type='table' AND "
                              "name='compaction'").fetchone():  # a journal of before it
                    for dropped, before in db.execute("SELECT dropped, before FROM compaction"):
                        record["compacted"] = int(dropped)
                        record["compacted_before"] = self.since_start(before)
        except sqlite3.Error as exc:
            record["error"] = f"{self.journal_path}: {exc}"
        self.writer.write("journal", **record)

    def record_log(self, components: set[str]) -> int:
        """Log lines of `components` and every warning or error, then a `log` record of
        how many (or of the error that kept the file from being read); returns how many."""
        count = 0
        path = log_file(self.run_dir)
        try:
            lines = read_history(path)  # its rotated files too: the whole run
        except OSError as exc:
            self.writer.write("log", t=self.now(), file=str(path), lines=0,
                              error=f"{path}: {exc.strerror or exc}")
            return 0
        for line in lines.splitlines():
            found = LOG_LINE.match(line)
            if not found:
                continue
            stamp, millis, component, pid, level, message = found.groups()
            if component not in components and level not in KEPT_LEVELS:
                continue
            wall = datetime.strptime(stamp, "%Y-%m-%d %H:%M:%S").timestamp() \
                + int(millis) / 1000
            self.writer.write("logline", t=self.since_start(wall), component=component,
                              pid=int(pid), level=level, message=message)
            count += 1
        self.writer.write("log", t=self.now(), file=str(path), lines=count)
        return count


class ReplyListener:
    """An MQTT subscriber on the reply topics that follows the broker across restarts."""

    def __init__(self, run_dir: Path, topics: list[str], sink: Any) -> None:
        self.run_dir, self.topics, self.sink = run_dir, topics, sink
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="chaos-replies", daemon=True)
        if topics:
            self._thread.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                url = (self.run_dir / "broker.url").read_text(encoding="utf-8").strip()
                address = parse_broker_url(url)
                client: mqtt.Client = new_client(f"mrss-chaos-replies-{id(self)}", address)
                client.on_message = self._on_message
                client.connect(address.host, address.port, keepalive=5)
                for topic in self.topics:
                    client.subscribe(topic, qos=1)
                while not self._stop.is_set() and client.loop(timeout=0.2) == 0:
                    pass
                client.disconnect()
            except (OSError, ValueError):
                pass
            self._stop.wait(0.5)

    def _on_message(self, _client: Any, _userdata: Any, msg: mqtt.MQTTMessage) -> None:
        # only the reply topics: a broker may hand a new session more (retained wills)
        if any(mqtt.topic_matches_sub(topic, msg.topic) for topic in self.topics):
            self.sink(msg.topic, msg.payload)

    def close(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=5)
