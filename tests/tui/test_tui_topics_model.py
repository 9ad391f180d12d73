"""The Messages view's model: topics as a tree, counts and rates summed upwards, each
topic's ring of latest messages, the envelope as pretty JSON (no Textual, no bus)."""

from __future__ import annotations

import dataclasses
import json

import pytest

from mrss.messages import Envelope, LogRecord, Message, RobotData
from mrss.tui.models import topics as topics_mod
from mrss.tui.models.topics import HISTORY, OVERFLOW, TopicsModel, pretty_json, summary


def env(body: Message, ts: float = 1000.0, src: str = "rcl", inc: int = 2,
        topic: str | None = None) -> Envelope:
    return Envelope(topic=topic or body.topic(), id=f"id{ts}", ts=ts, src=src, inc=inc,
                    body=body)


def data(robot: str, level: float) -> RobotData:
    return RobotData(robot=robot, data={"type": "tank", "level": level, "capacity": 200.0})


def test_topics_become_a_tree_of_levels_with_counts_summed_upwards() -> None:
    model = TopicsModel()
    model.count([env(data("uav1", 1)), env(data("uav1", 2)), env(data("ugv1", 3))], now=100.0)
    model.count([env(LogRecord(level="INFO", component="rcl", message="hi"))], now=100.5)
    root = model.tree(now=100.5)
    assert [c.name for c in root.sorted_children()] == ["log", "robot"]
    robot = root.children["robot"]
    assert robot.count == 3 and root.count == 4 and model.total == 4
    assert sorted(robot.children) == ["uav1", "ugv1"]
    leaf = robot.children["uav1"].children["data"]
    assert (leaf.path, leaf.count) == ("robot.uav1.data", 2)
    assert leaf.stats is not None and robot.stats is None  # a level is no topic
    assert leaf.label().startswith("data  2 · ")


def test_the_rate_is_messages_per_second_over_a_sliding_window() -> None:
    model = TopicsModel()
    for second in range(20):  # 5 a second for 20 s
        model.count([env(data("uav1", i)) for i in range(5)], now=100.0 + second)
    stats = model.topics["robot.uav1.data"]
    assert stats.rate(119.5) == 5.0  # the last 10 s, not the 20 seen
    assert model.tree(now=119.5).children["robot"].rate == 5.0
    assert stats.rate(125.0) == 2.0  # silent since 119: seconds 116..119 are in the window
    assert stats.rate(140.0) == 0.0  # long silent
    young = TopicsModel()
    young.count([env(data("ugv1", 1)), env(data("ugv1", 2))], now=50.0)
    assert young.topics["robot.ugv1.data"].rate(52.0) == 1.0  # since its first message
    assert len(stats.buckets) <= topics_mod.WINDOW + 1  # old buckets are dropped


def test_each_topic_keeps_its_latest_messages_newest_first() -> None:
    model = TopicsModel()
    model.count([env(data("uav1", float(i)), ts=1000.0 + i) for i in range(HISTORY + 7)], now=1.0)
    history = model.history("robot.uav1.data")
    assert len(history) == HISTORY
    assert history[0].ts == 1000.0 + HISTORY + 6 and history[-1].ts == 1007.0
    assert model.latest("robot.uav1.data") is history[0]
    assert model.latest("robot") is None and model.history("nothing") == []
    assert model.topics["robot.uav1.data"].count == HISTORY + 7


def test_the_latest_message_is_the_whole_envelope_as_pretty_json() -> None:
    model = TopicsModel()
    model.count([env(data("ugv1", float("nan")), ts=1234.5, src="rcl", inc=3)], now=1.0)
    latest = model.latest("robot.ugv1.data")
    assert latest is not None
    text = pretty_json(latest)
    parsed = json.loads(text)  # valid JSON, NaN shown as text
    assert parsed == {"topic": "robot.ugv1.data", "kind": "robot.data", "src": "rcl", "inc": 3,
                      "ts": 1234.5, "id": "id1234.5",
                      "body": {"robot": "ugv1", "data": {"type": "tank", "level": "nan",
                                                         "capacity": 200.0}}}
    assert "\n  " in text  # indented
    line = summary(latest, width=40)
    assert line.split()[1] == "rcl#3" and '{"robot":"ugv1"' in line
    assert len(line) == 40 and line.endswith("…")


def test_a_replayed_message_is_shown_as_replayed() -> None:
    model = TopicsModel()
    replayed = dataclasses.replace(env(data("ugv1", 60.0), src="rcl", inc=2), replayed=True)
    model.count([replayed], now=1.0)
    latest = model.latest("robot.ugv1.data")
    assert latest is not None and json.loads(pretty_json(latest))["replayed"] is True
    assert summary(latest).split()[1:3] == ["rcl#2", "(replayed)"]


def test_topics_beyond_the_limit_are_counted_together(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(topics_mod, "MAX_TOPICS", 3)
    model = TopicsModel()
    model.count([env(data(f"r{i}", 1.0)) for i in range(5)], now=1.0)
    assert len(model.topics) == 4 and model.topics[OVERFLOW].count == 2
    assert model.tree(now=1.0).children[OVERFLOW].count == 2
