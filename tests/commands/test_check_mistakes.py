"""Seeded mistakes: the template project with one mistake each, as `mrss check` reports it.

Every case copies projects/template, injects one mistake into one file and runs
`mrss check --json` (in process, the real CLI): the exit code is 2, and the error names
the file, the line where the mistake is (found by a marker in the mutated file), and
what was expected. `mrss supervise` refuses to start such a project (exit 2).
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from mrss.cli import main

TEMPLATE = Path(__file__).resolve().parents[2] / "projects" / "template"
SIM_UAV = '\n[components.sim_uav]\nkind = "sim_uav"\n'
ROBOT2 = '\n[components.rcl.robots.robot2]\nlink = "mavlink"\n'
REACHED = '      .print("goal ", G, " reached");'


@dataclass(frozen=True)
class Mistake:
    """One mistake: in `file`, replace `old` by `new` (or append `new` when old is "")."""

    name: str
    file: str
    old: str
    new: str
    marker: str  # the text on the line the error must point at
    message: str  # a regex the error's message must match
    reported_in: str = ""  # the file the error is in, when not `file`


MISTAKES = [
    # project.toml
    Mistake("component key misspelt", "project.toml", "shutdown = 2.0", "shutdwon = 2.0",
            "shutdwon", r"unknown option .*did you mean 'shutdown'\?"),
    Mistake("events option misspelt", "project.toml", 'topic_prefix = "mrss/ui"',
            'topic_prefx = "mrss/ui"', "topic_prefx",
            r"unknown option of \[events\].*did you mean 'topic_prefix'\?"),
    Mistake("simulator option misspelt", "project.toml", "", SIM_UAV + "endurence = 900.0\n",
            "endurence", r"unknown option of SimUavComponent.*did you mean 'endurance'\?"),
    Mistake("simulator option of the wrong type", "project.toml", "",
            SIM_UAV + 'speedup = "fast"\n', "speedup", r"expected a number, not 'fast'"),
    Mistake("link URL with a bad port", "project.toml", "",
            ROBOT2 + 'url = "udpin:127.0.0.1:notaport"\n', "notaport",
            r"port 'notaport' .* is not a port number"),
    Mistake("link timeout of zero", "project.toml", "",
            ROBOT2 + 'url = "udpin:127.0.0.1:14550"\nheartbeat_timeout = 0\n',
            "heartbeat_timeout", r"must be a positive number of seconds, got 0"),
    Mistake("world model URL of another database", "project.toml", "[worldmodel]\n",
            '[worldmodel]\nurl = "mysql://db:3306/world"\n', "mysql://",
            r"not a PostgreSQL URL; did you mean postgresql://"),
    Mistake("MQTT broker URL that does not parse", "project.toml", "",
            '\n[components.rcl.robots.robot3]\nlink = "mqtt"\nbroker_url = "mqtt://host:x1"\n',
            "host:x1", r"not a valid URL 'mqtt://host:x1'"),
    Mistake("unknown link option", "project.toml", "", ROBOT2 + 'url = "udpin:0.0.0.0:14550"\n'
            "retires = 3\n", "retires", r"not a mavlink link option; did you mean 'retries'\?"),
    Mistake("unknown HTTP link option", "project.toml", "",
            '\n[components.rcl.robots.robot4]\nlink = "http"\nurl = "http://10.0.0.7:8080"\n'
            "pol = 0.5\n", "pol =", r"not a http link option; did you mean 'poll'\?"),
    Mistake("world model seed file missing", "project.toml", '# seed = "world.json"',
            'seed = "nosuch.json"', "nosuch.json", r"no file 'nosuch.json' in the project"),
    Mistake("unknown table", "project.toml", "[datalayer]", "[datalayr]", "[datalayr]",
            r"unknown table \[datalayr\]; did you mean 'datalayer'\?"),
    Mistake("data layer option out of range", "project.toml", "[datalayer]",
            "[datalayer]\ncall_timeout = -1", "call_timeout", r"expected a number > 0"),
    Mistake("robot data limit that is not a range", "project.toml", "[datalayer]",
            "[datalayer]\nalt_range = [500, -500]", "alt_range",
            r"expected \[low, high\] \(finite numbers, low <= high\)"),
    Mistake("component kind misspelt", "project.toml", 'kind = "reasoner"',
            'kind = "reasonr"', "reasonr",
            r"must be one of bus, .*, not 'reasonr'; did you mean 'reasoner'\?"),
    Mistake("adapter class that does not exist", "project.toml", "[events]",
            '[events]\nclass = "FloodEvents"', "FloodEvents",
            r"class 'FloodEvents' is not defined in events.py; events.py defines the "
            r"ExternalAdapter subclasses: ProjectEvents"),
    Mistake("agent file missing", "project.toml", "[components.reasoner]",
            '[components.reasoner]\nagent = "flood.asl"', "flood.asl",
            r"no file 'flood.asl' in the project folder"),
    Mistake("agents entry key misspelt", "project.toml", "[components.reasoner]",
            '[components.reasoner]\nagents = [\n  { name = "main", file = "agent.asl" },\n'
            '  { name = "helper", fil = "agent.asl" },\n]', "fil =",
            r"agent 2 of agents: unknown key 'fil' of an agent; did you mean 'file'\?"),
    Mistake("agents entry named twice", "project.toml", "[components.reasoner]",
            '[components.reasoner]\nagents = [{ name = "main", file = "agent.asl" },\n'
            '  { name = "main", file = "agent.asl" }]', '{ name = "main", file = "agent.asl" }]',
            r"agent 2 of agents: two agents are named 'main'"),
    Mistake("bus option misspelt", "project.toml", "", '\n[bus]\ntransprt = "tcp"\n',
            "transprt", r"unknown option of \[bus\].*did you mean 'transport'\?"),
    Mistake("bus transport not one of its choices", "project.toml", "",
            '\n[bus]\ntransport = "tpc"\n', "tpc",
            r"expected 'ipc' or 'tcp', not 'tpc'; did you mean 'tcp'\?"),
    Mistake("log rotation option misspelt", "project.toml", "", "\n[logs]\nmax_mbs = 5\n",
            "max_mbs", r"unknown option of \[logs\].*did you mean 'max_mb'\?"),
    Mistake("log rotation keeping no file", "project.toml", "", "\n[logs]\nkeep = 0\n",
            "keep = 0", r"expected a number > 0"),
    Mistake("broker option misspelt", "project.toml",
            '# [broker]\n# url = "mqtt://host:1883"', '[broker]\nurls = "mqtt://host:1883"',
            "urls =",
            r"unknown option of \[broker\].*did you mean 'url'\?"),
    Mistake("broker URL that does not parse", "project.toml", "",
            '\n[broker]\nurl = "mqtt://broker:nope"\n', "broker:nope",
            r"not a valid URL 'mqtt://broker:nope'"),
    Mistake("embedded broker port of the wrong type", "project.toml", "",
            '\n[broker.embedded]\nport = "1883"\n', "port =",
            r"expected an integer, not '1883'"),
    Mistake("layer's robot setting of the wrong type", "project.toml", "speed = 50.0",
            'speed = "fast"', 'speed = "fast"', r"expected a number, not 'fast' \(m/s"),
    Mistake("layer's robot setting out of range", "project.toml", "speed = 50.0",
            "speed = -1.0", "speed = -1.0", r"expected a number > 0, not -1.0"),
    Mistake("MAVLink signing key file missing", "project.toml", "",
            ROBOT2 + 'url = "udpin:0.0.0.0:14550"\nsigning_key = "keys/robot2.key"\n',
            "keys/robot2.key", r"cannot read signing key file 'keys/robot2.key'"),
    Mistake("MAVLink signing key that is not 64 hex characters", "project.toml", "",
            ROBOT2 + 'url = "udpin:0.0.0.0:14550"\nsigning_key = "agent.asl"\n',
            'signing_key = "agent.asl"', r"must hold 32 bytes as 64 hexadecimal characters"),
    Mistake("MQTT robot CA file missing", "project.toml", "",
            '\n[components.rcl.robots.robot2]\nlink = "mqtt"\nusername = "robot2"\n'
            'ca_certs = "tls/ca.pem"\n', "tls/ca.pem",
            r"no file 'tls/ca.pem' in the project folder"),
    Mistake("simulator signing key file missing", "project.toml", "",
            SIM_UAV + 'signing_key = "keys/uav.key"\n', "keys/uav.key",
            r"cannot read signing key file 'keys/uav.key'"),
    Mistake("world model served beyond loopback without a token", "project.toml",
            "[worldmodel]", '[worldmodel]\nhttp_host = "10.1.2.3"', "10.1.2.3",
            r"http_host '10.1.2.3' is not a loopback address.*set \[worldmodel\] token_file"),
    Mistake("world model token file missing", "project.toml", "[worldmodel]",
            '[worldmodel]\ntoken_file = "secrets/wm.token"', "secrets/wm.token",
            r"cannot read token file 'secrets/wm.token'"),
    Mistake("world model token too short", "project.toml", "[worldmodel]",
            '[worldmodel]\ntoken_file = "agent.asl"', 'token_file = "agent.asl"',
            r"must be 16 to 512 characters|visible ASCII characters without spaces"),
    Mistake("embedded broker password file missing", "project.toml", "",
            '\n[broker]\nusername = "ops"\npassword_env = "MQTT_PASSWORD"\n'
            '[broker.embedded]\npassword_file = "secrets/broker.passwd"\n', "broker.passwd",
            r"cannot read password file 'secrets/broker.passwd'"),
    Mistake("robot id not an atom", "project.toml", "[components.rcl.robots.robot1]",
            "[components.rcl.robots.Robot1]", "Robot1", r"a robot id must be a lowercase"),
    # agent.asl
    Mistake("agent syntax error", "agent.asl", "+free(R);\n      .print(\"goal \", G, \" reached",
            "+free(R)\n      .print(\"goal \", G, \" reached", ".print(\"goal \", G, \" reached",
            r"expected|unexpected"),
    Mistake("action without a recipe", "agent.asl", "move(R, G, Lat, Lon);",
            "mvoe(R, G, Lat, Lon);", "mvoe(", r"action mvoe/4: .*no recipe.*did you mean "
            r"'move'\?"),
    Mistake("action with an arity no recipe has", "agent.asl", "move(R, G, Lat, Lon);",
            "move(R, G, Lat);", "move(R, G, Lat);", r"action move/3: .*handles only move/4"),
    Mistake("query of a function the data layer lacks", "agent.asl", "      -busy(R, G);\n"
            "      +free(R);\n      .print(\"goal \", G, \" reached\");",
            "      -busy(R, G);\n      +free(R);\n      query(distanse_to, [R, Lat, Lon], D);\n"
            "      .print(\"goal \", G, \" reached\");", "distanse_to",
            r"defines no function 'distanse_to'; did you mean 'distance_to'\?"),
    # agent.asl about project.toml's robots and datalayer.py's functions (cross-file)
    Mistake("belief naming a robot no robot table has", "agent.asl", "free(robot1).",
            "free(robot2).", "free(robot2)", r"'robot2' is not a robot: argument 1 of free/1 "
            r"holds a robot id.*defines the robots robot1; did you mean 'robot1'\?"),
    Mistake("action on a robot id no robot table has", "agent.asl",
            "   <- move(R, G, Lat, Lon);", "   <- move(robot3, G, Lat, Lon);", "move(robot3",
            r"'robot3' is not a robot: argument 1 of move/4"),
    Mistake("query with an argument too few", "agent.asl", REACHED,
            "      query(distance_to, [R, Lat], D);\n" + REACHED, "[R, Lat], D",
            r"query\(distance_to, \.\.\.\): 2 argument\(s\) do not fit "
            r"distance_to\(object_id, lat, lon\) \(datalayer.py:\d+\)"),
    Mistake("query result matched as a list, the function returns a number", "agent.asl",
            REACHED, "      query(distance_to, [R, Lat, Lon], [D]);\n" + REACHED, "[D]",
            r"the agent expects a list, but distance_to\(.*\) returns a number \(float\)"),
    Mistake("query result used as a list, the function returns a number", "agent.asl",
            REACHED, "      query(distance_to, [R, Lat, Lon], D); .member(X, D);\n" + REACHED,
            ".member(X, D)", r"expects a list \(used so at line \d+:\d+\), but distance_to"),
    # rcl.py
    Mistake("recipe passing a keyword the skill's constructor does not take", "rcl.py",
            "skills.MoveTo(float(lat), float(lon))",
            "skills.MoveTo(float(lat), float(lon), speeed=2.0)", "speeed",
            r"skills.MoveTo\(\.\.\.\) does not fit MoveTo\(lat, lon\) \(skills.py:\d+\): "
            r"got an unexpected keyword argument 'speeed'"),
    Mistake("skill constructor that needs more than the recipes pass", "skills.py",
            "def __init__(self, lat: float, lon: float) -> None:",
            "def __init__(self, lat: float, lon: float, alt: float) -> None:",
            "skills.MoveTo(", r"does not fit MoveTo\(lat, lon, alt\).*missing a required "
            r"argument: 'alt'", reported_in="rcl.py"),
    Mistake("recipe naming a skill skills.py lacks", "rcl.py", "skills.MoveTo(",
            "skills.MoveTwo(", "MoveTwo", r"uses skill 'MoveTwo', which skills.py does not "
            r"define; did you mean 'MoveTo'\?"),
    Mistake("rcl.py syntax error", "rcl.py", "def refine_action(self, action: Action)",
            "def refine_action(self, action: Action", "def refine_action",
            r"syntax error"),
    Mistake("layer class named in project.toml missing", "project.toml",
            "[components.rcl]", '[components.rcl]\nlayer = "rcl.py:FloodRcl"', "FloodRcl",
            r"class 'FloodRcl' is not defined in rcl.py.*ProjectRcl"),
    # skills.py
    Mistake("skill run with an extra required parameter", "skills.py",
            "def run(self) -> bool:", "def run(self, speed: float) -> bool:", "def run(",
            r"MoveTo.run\(self, speed\) does not match Skill.run\(self\)"),
    Mistake("skill finish without its outcome", "skills.py",
            "def finish(self, outcome: SkillOutcome) -> None:", "def finish(self) -> None:",
            "def finish(", r"MoveTo.finish\(self\).* the RCL calls finish\(outcome\)"),
    # events.py, datalayer.py
    Mistake("payload schema field of an unknown kind", "events.py",
            'Field("goal", "atom"), Field("lat", "lat")',
            'Field("goal", "atm"), Field("lat", "lat")', '"atm"',
            r"field 'goal': unknown kind 'atm'; did you mean 'atom'\?"),
    Mistake("events.py import error", "events.py", "from mrss.api import",
            "from mrss.nowhere import Thing\nfrom mrss.api import", "mrss.nowhere",
            r"import failed: .*mrss.nowhere"),
    Mistake("two data layers and none named", "datalayer.py", "", "\n\nclass Second(ProjectData):"
            "\n    pass\n", "class Second", r"several subclasses of DataLayer \(ProjectData, "
            r"Second\)"),
]


@pytest.fixture()
def project(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    folder = tmp_path / "projects" / "flood"
    shutil.copytree(TEMPLATE, folder, ignore=shutil.ignore_patterns("__pycache__",
                                                                     "procedures"))
    monkeypatch.setenv("MRSS_PROJECTS", str(folder.parent))
    return folder


def inject(project: Path, mistake: Mistake) -> None:
    path = project / mistake.file
    text = path.read_text(encoding="utf-8")
    if mistake.old:
        assert text.count(mistake.old) == 1, f"{mistake.name}: {mistake.old!r} not unique"
        text = text.replace(mistake.old, mistake.new)
    else:
        text += mistake.new
    path.write_text(text, encoding="utf-8")


def run_check(capsys: pytest.CaptureFixture[str]) -> tuple[int, dict[str, Any]]:
    code = main(["check", "flood", "--json"])
    return code, json.loads(capsys.readouterr().out)


def line_of(path: Path, marker: str) -> int:
    lines = path.read_text(encoding="utf-8").splitlines()
    found = [n for n, line in enumerate(lines, start=1) if marker in line]
    assert len(found) == 1, f"marker {marker!r} on lines {found}"
    return found[0]


def test_the_template_has_no_finding(project: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, report = run_check(capsys)
    assert code == 0 and report["ok"], report
    assert report["findings"] == []


@pytest.mark.parametrize("mistake", MISTAKES, ids=[m.name for m in MISTAKES])
def test_check_reports_the_mistake_at_its_file_and_line(
        project: Path, capsys: pytest.CaptureFixture[str], mistake: Mistake) -> None:
    inject(project, mistake)
    code, report = run_check(capsys)
    assert code == 2, report
    errors = [f for f in report["findings"] if f["severity"] == "error"]
    reported = project / (mistake.reported_in or mistake.file)
    expected_line = line_of(reported, mistake.marker)
    matching = [f for f in errors if re.search(mistake.message, f["message"])]
    assert matching, errors
    assert [(f["file"], f["line"]) for f in matching] == [(str(reported), expected_line)]
    assert len(errors) == 1, errors  # one mistake, one error: nothing follows from it


def test_the_mistakes_are_distinct() -> None:
    assert len(MISTAKES) >= 20
    assert len({(m.file, m.old, m.new) for m in MISTAKES}) == len(MISTAKES)
    assert {m.file for m in MISTAKES} >= {"project.toml", "agent.asl", "rcl.py", "skills.py",
                                          "events.py", "datalayer.py"}


def test_a_broken_skills_py_is_one_error_and_says_what_was_not_checked(
        project: Path, capsys: pytest.CaptureFixture[str]) -> None:
    inject(project, Mistake("", "skills.py", "class MoveTo(Skill):", "class MoveTo(Skill:",
                            "", ""))
    code, report = run_check(capsys)
    assert code == 2
    errors = [f for f in report["findings"] if f["severity"] == "error"]
    assert [(Path(f["file"]).name, f["line"]) for f in errors] == [
        ("skills.py", line_of(project / "skills.py", "class MoveTo(Skill:"))]
    assert any(f["file"] == str(project / "rcl.py") and "not checked: it imports skills.py"
               in f["message"] for f in report["findings"]), report


def test_orphan_percepts_are_warnings_on_both_sides(
        project: Path, capsys: pytest.CaptureFixture[str]) -> None:
    inject(project, Mistake("", "events.py", 'JsonMapping("goal_cancelled"',
                            'JsonMapping("goal_canceled"', "", ""))
    code, report = run_check(capsys)
    assert code == 0, report
    warnings = {(Path(f["file"]).name, f["line"]): f["message"] for f in report["findings"]}
    events_line = line_of(project / "events.py", "goal_canceled")
    assert "percept goal_canceled/1 is never handled" in warnings[("events.py", events_line)]
    agent_line = line_of(project / "agent.asl", "+goal_cancelled(G)[source(percept)] : busy")
    assert "no part of the project produces this percept" in \
        warnings[("agent.asl", agent_line)]


def test_the_rcls_reassigned_percept_is_known_to_be_produced(
        project: Path, capsys: pytest.CaptureFixture[str]) -> None:
    with (project / "agent.asl").open("a") as asl:  # the RCL's, for tasks addressed to a role
        asl.write("\n+reassigned(Task, From, To)[source(percept)]\n"
                  "   <- .print(Task, \" went from \", From, \" to \", To).\n")
    code, report = run_check(capsys)
    assert code == 0, report
    assert not [f for f in report["findings"] if "reassigned" in f["message"]], report


def test_text_output_names_file_line_and_column(
        project: Path, capsys: pytest.CaptureFixture[str]) -> None:
    inject(project, next(m for m in MISTAKES if m.name == "action without a recipe"))
    assert main(["check", "flood"]) == 2
    err = capsys.readouterr().err
    line = line_of(project / "agent.asl", "mvoe(")
    col = (project / "agent.asl").read_text().splitlines()[line - 1].index("mvoe(") + 1
    assert f"{project / 'agent.asl'}:{line}:{col}: action mvoe/4" in err


def test_supervise_refuses_to_start_a_project_with_an_error(project: Path) -> None:
    inject(project, MISTAKES[0])
    env = dict(os.environ, MRSS_PROJECTS=str(project.parent))
    out = subprocess.run([sys.executable, "-m", "mrss", "supervise", "flood", "--no-tui",
                          "--run-dir", str(project.parent / "run")], capture_output=True,
                         text=True, timeout=120, env=env)
    assert out.returncode == 2, out.stderr
    assert f"{project / 'project.toml'}:{line_of(project / 'project.toml', 'shutdwon')}" \
        in out.stderr
    assert "not started" in out.stderr
    assert not (project.parent / "run").exists() or \
        not list((project.parent / "run").glob("*.sqlite3"))  # nothing ran


def test_an_adapter_of_an_earlier_release_without_options_warns_with_the_declaration(
        project: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """An adapter written before options were declared reads keys it does not declare:
    each is a warning (at its line, with the one-line OPTIONS to add), not a refusal."""
    inject(project, Mistake("", "events.py", '    OPTIONS = (Option("topic_prefix", str, '
                            '"mrss/ui", "prefix of the UI\'s topics"),)\n', "", "", ""))
    inject(project, Mistake("", "project.toml", "[events]  ", '[events]\nzone = "north"\n  ', "",
                            ""))
    code, report = run_check(capsys)
    assert code == 0, report
    (finding,) = [f for f in report["findings"] if f["key"] == "events.zone"]
    assert finding["severity"] == "warning"
    assert finding["line"] == line_of(project / "project.toml", 'zone = "north"')
    assert "if ProjectEvents reads it, add to the class: OPTIONS = (Option('zone', str, " \
           "'north', " in finding["message"]


def test_an_adapter_that_declares_options_still_has_unknown_keys_refused(
        project: Path, capsys: pytest.CaptureFixture[str]) -> None:
    inject(project, Mistake("", "project.toml", "[events]  ", '[events]\nzone = "north"\n  ', "",
                            ""))
    code, report = run_check(capsys)
    assert code == 2
    (finding,) = [f for f in report["findings"] if f["key"] == "events.zone"]
    assert finding["severity"] == "error" and "unknown option of [events]" in finding["message"]


def test_the_geofence_on_without_a_plan_for_its_percept_is_a_warning(
        project: Path, capsys: pytest.CaptureFixture[str]) -> None:
    inject(project, Mistake("", "project.toml", "\n[datalayer]", "\n[datalayer]\ngeofence = true",
                            "", ""))
    code, report = run_check(capsys)
    assert code == 0, report
    messages = [f["message"] for f in report["findings"]]
    assert any("geofence is on but agent.asl has no +geofence_exit(Robot, Zone, Lat, Lon) "
               "plan" in m for m in messages), messages
    inject(project, Mistake("", "project.toml", "geofence = true", 'geofence = "yes"', "", ""))
    code, report = run_check(capsys)
    assert code == 2 and any("datalayer.geofence" in f["message"] or "geofence" in f["message"]
                             and "true or false" in f["message"]
                             for f in report["findings"]), report


def test_amadee_checks_clean_with_its_geofence(monkeypatch: pytest.MonkeyPatch,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setenv("MRSS_PROJECTS", str(TEMPLATE.parent))
    assert main(["check", "amadee", "--json"]) == 0
    findings = json.loads(capsys.readouterr().out)["findings"]
    assert not [f for f in findings if "geofence" in f["message"]], findings
