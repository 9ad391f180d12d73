"""A project's own alert rules (`[[alerts]]`): read, checked by `mrss check` at their
line, raised and ended by the alerts model; one alert acknowledged alone (no Textual)."""

from __future__ import annotations

from pathlib import Path

import pytest

from mrss.check import check_project
from mrss.config.alerts import AlertRule, Severity, project_alert_rules, read_alert_rules
from mrss.config.loader import load_file
from mrss.errors import ConfigError
from mrss.messages import Envelope, Message, RobotData
from mrss.tui.models.alerts import AlertKind, AlertsModel

WILDFIRE = Path(__file__).resolve().parents[2] / "projects" / "wildfire" / "project.toml"


def env(body: Message, ts: float = 100.0) -> Envelope:
    return Envelope(topic=body.topic(), id="1", ts=ts, src="rcl", inc=0, body=body)


def tank(robot: str, level: float) -> Envelope:
    return env(RobotData(robot=robot, data={"type": "tank", "level": level, "capacity": 200}))


def test_rules_are_read_and_their_mistakes_named_with_the_key() -> None:
    rules = read_alert_rules([{"name": "water low", "field": "tank.level", "below": 50,
                               "robot": "ugv1"},
                              {"name": "hot", "field": "temp", "above": 70.5,
                               "severity": "severe"}])
    assert rules == (AlertRule("water low", "tank.level", below=50.0, robot="ugv1"),
                     AlertRule("hot", "temp", above=70.5, severity=Severity.SEVERE))
    assert (rules[0].record, rules[0].key, rules[1].record) == ("tank", "level", "")
    assert read_alert_rules(None) == ()
    assert [rules[0].text(v) for v in (31, 120)] == ["tank.level 31 < 50", "tank.level 120"]
    assert rules[1].text(71) == "temp 71 > 70.5"
    bad = [({"alerts": {"name": "x"}}, "alerts", "array of tables"),
           ([{"name": "x", "feild": "a", "below": 1}], "alerts[1].feild",
            "did you mean 'field'"),
           ([{"field": "a", "below": 1}], "alerts[1]", "name.*is missing"),
           ([{"name": "x", "field": "a"}], "alerts[1]", "needs a threshold"),
           ([{"name": "x", "field": "a", "below": "low"}], "alerts[1].below", "a number"),
           ([{"name": "x", "field": "a", "below": 9, "above": 1}], "alerts[1].below",
            "always be on"),
           ([{"name": "x", "field": "a.", "below": 1}], "alerts[1].field", "record.key"),
           ([{"name": "x", "field": "a", "below": 1, "severity": "sever"}],
            "alerts[1].severity", "did you mean 'severe'"),
           ([{"name": "x", "field": "a", "below": 1}, {"name": "x", "field": "b", "above": 1}],
            "alerts[2].name", "second rule named 'x'")]
    for value, key, problem in bad:
        raw = value["alerts"] if isinstance(value, dict) else value
        with pytest.raises(ConfigError, match=problem) as caught:
            read_alert_rules(raw, file="p.toml")
        assert caught.value.key == key, (value, caught.value)


def test_a_rule_raises_its_alert_while_the_field_is_out_and_ends_it_when_back() -> None:
    rules = read_alert_rules([{"name": "water low", "field": "tank.level", "below": 50,
                               "robot": "ugv1", "severity": "severe"},
                              {"name": "hot", "field": "temp", "above": 70}])
    model = AlertsModel(rules=rules)
    assert model.apply(tank("ugv1", 120)) == []
    assert model.apply(tank("ugv2", 10)) == []  # the rule is for ugv1 only
    raised = model.apply(tank("ugv1", 31))
    assert [(a.kind, a.label, a.subject, a.text, a.severe) for a in raised] == [
        (AlertKind.RULE, "water low", "ugv1", "tank.level 31 < 50", True)]
    assert raised[0].line() == "water low: ugv1 tank.level 31 < 50"
    assert model.apply(tank("ugv1", 20)) == []  # still low: the detail follows
    assert model.unacked()[0].text == "tank.level 20 < 50"
    model.apply(tank("ugv1", 200))
    assert model.unacked()[0].resolved
    # a flat record's field; any robot; not severe
    hot = model.apply(env(RobotData(robot="r9", data={"temp": 80, "battery": 90})))
    assert [(a.label, a.subject, a.severe) for a in hot] == [("hot", "r9", False)]
    assert model.apply(env(RobotData(robot="r9", data={"type": "x", "temp": 99}))) == []


def test_one_alert_is_acknowledged_alone() -> None:
    model = AlertsModel(rules=read_alert_rules([{"name": "hot", "field": "temp", "above": 70}]))
    model.apply(env(RobotData(robot="a", data={"temp": 80})))
    model.apply(env(RobotData(robot="b", data={"temp": 90})))
    assert [a.subject for a in model.unacked()] == ["b", "a"]
    assert model.acknowledge_one(("hot", "a"))
    assert not model.acknowledge_one(("hot", "a"))  # already
    assert not model.acknowledge_one(("hot", "nobody"))
    assert [a.subject for a in model.unacked()] == ["b"]
    assert model.acknowledge() == 1 and model.unacked() == []


def test_wildfire_declares_water_low_for_its_ugv() -> None:
    config = load_file(WILDFIRE)
    rules = project_alert_rules(config.sections, str(config.file))
    assert [(r.name, r.robot, r.field, r.below) for r in rules] == [
        ("water low", "ugv1", "tank.level", 50.0)]


PROJECT = """\
[project]
name = "alertsdemo"

[components.bus]
kind = "bus"

[components.rcl]
kind = "rcl"
robots = {{ ugv1 = {{ leg = 0.3 }} }}

[[alerts]]
name = "ok"
field = "battery"
below = 10

[[alerts]]
name = "water low"
{line}
below = 50
"""


@pytest.mark.parametrize(("line", "message", "key"), [
    ('feild = "tank.level"', "unknown key 'feild'; did you mean 'field'?", "alerts[2].feild"),
    ('field = "tank.level"\nseverity = "loud"', "must be one of warning, severe",
     "alerts[2].severity"),
])
def test_mrss_check_names_a_bad_rule_at_its_line(tmp_path: Path, line: str, message: str,
                                                 key: str) -> None:
    toml = tmp_path / "project.toml"
    text = PROJECT.format(line=line)
    toml.write_text(text)
    errors = [f for f in check_project(load_file(toml)).errors if f.check == "alerts"]
    assert len(errors) == 1 and message in errors[0].message, errors
    assert errors[0].key == key
    bad_line = line.splitlines()[-1]
    assert errors[0].line == text.splitlines().index(bad_line) + 1


def test_mrss_check_warns_of_a_rule_for_an_unknown_robot(tmp_path: Path) -> None:
    toml = tmp_path / "project.toml"
    text = PROJECT.format(line='field = "tank.level"\nrobot = "ugv2"')
    toml.write_text(text)
    report = check_project(load_file(toml))
    assert not [f for f in report.errors if f.check == "alerts"]
    warnings = [f for f in report.warnings if f.check == "alerts"]
    assert len(warnings) == 1 and "no RCL declares robot 'ugv2'; did you mean 'ugv1'?" \
        in warnings[0].message
    assert warnings[0].line == text.splitlines().index('robot = "ugv2"') + 1
    assert any("alerts: 2 rules (ok, water low)" in line for line in report.summary)


def test_the_documented_rules_read() -> None:
    """Every ```toml block of the docs that declares [[alerts]] reads as rules."""
    import re
    import tomllib

    docs = Path(__file__).resolve().parents[2] / "docs"
    blocks = [block for doc in ("config.md", "tui.md")
              for block in re.findall(r"```toml\n(.*?)```", (docs / doc).read_text(), re.S)
              if "[[alerts]]" in block]
    assert len(blocks) == 2
    rules = [read_alert_rules(tomllib.loads(block)["alerts"]) for block in blocks]
    assert [r.name for r in rules[0]] == ["water low", "motor hot"]
    assert rules[0][1] == AlertRule("motor hot", "motor.temperature", above=80.0,
                                    severity=Severity.SEVERE)
    assert rules[1] == (AlertRule("water low", "tank.level", below=50.0, robot="ugv1"),)
