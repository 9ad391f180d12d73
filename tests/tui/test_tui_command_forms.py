"""The project's declared operator commands ([operator.commands]) as forms on the
mission panel: every field type, every mistake refused in the form with nothing sent,
at 80x24 too; and, against a live system (MQTT, the events manager, the wildfire
agent), a command that reaches the agent and the agent's answer with its reason."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from textual.widgets import Input, OptionList

from mrss.bus import BusEndpoints
from mrss.config.loader import load_project
from mrss.config.operator import read_operator
from mrss.tui.app import MrssApp
from mrss.tui.command_form import CommandForm, CommandMenu
from mrss.tui.mission import MissionChannel, project_mission
from mrss.tui.widgets.mission_panel import MissionPanel
from mrss.tui.widgets.operator_bar import OperatorBar
from tests.tui.conftest import HERE
from tests.tui.tui_helpers import has_row, row_text, run, until

EVERY_TYPE = {"commands": {"probe": {
    "label": "Every field type",
    "percept": "probe(Site, Zone, Ring, Depth, Tool, Note)",
    "goal": "site",
    "fields": [
        {"name": "site", "type": "point"},
        {"name": "zone", "type": "polygon", "max_vertices": 5},
        {"name": "ring", "type": "circle", "min": 10, "max": 500, "units": "m"},
        {"name": "depth", "type": "number", "min": 0, "max": 2, "units": "m", "default": 1},
        {"name": "tool", "type": "choice", "choices": ["drill", "scoop"], "default": "drill"},
        {"name": "note", "type": "text", "default": "ok"},
    ]}}}
GOOD = {"site": "47.07,15.43", "zone": "47,15; 47,15.01; 47.01,15.01",
        "ring": "47.07,15.43,100", "depth": "1.5", "tool": "scoop", "note": "careful"}
# one mistake per field type; the message names the field, and nothing is sent
MISTAKES = [
    ("site", "95,15", "site: 95,15 is not a position"),
    ("site", "north", "site: 'north' is not LAT,LON"),
    ("zone", "0,0; 1,1; 1,0; 0,1", "zone: the polygon crosses itself"),
    ("zone", "0,0; 0,1; 1,1; 1,0.5; 1,0; 0.5,0", "zone: 6 vertices, at most 5"),
    ("zone", "0,0; 0,1", "zone: a polygon needs at least 3 vertices"),
    ("ring", "47,15,5000", "ring: radius 5000 m is out of range (10 to 500)"),
    ("ring", "47,15", "ring: '47,15' is not LAT,LON,RADIUS"),
    ("depth", "3", "depth: value 3 m is out of range (0 to 2)"),
    ("depth", "deep", "depth: 'deep' is not a number"),
    ("tool", "scop", "tool: 'scop' is not one of drill, scoop; did you mean 'scoop'?"),
    ("note", "", "note: required"),
]


def _app(endpoints: BusEndpoints, size: tuple[int, int]) -> tuple[MrssApp, MissionChannel]:
    config = read_operator(EVERY_TYPE)
    channel = MissionChannel(config, lambda: None)  # no broker: a send would say so
    return MrssApp(endpoints, project="forms", mind_every=0, tree_every=0,
                   mission=channel), channel


@pytest.mark.parametrize("size", [(180, 50), (80, 24)])
def test_every_field_type_is_checked_in_its_form_and_a_mistake_sends_nothing(
        endpoints: BusEndpoints, size: tuple[int, int]) -> None:
    async def body() -> None:
        app, channel = _app(endpoints, size)
        sent: list[Any] = []
        app.steering.mission_requested = sent.append  # type: ignore[method-assign]
        async with app.run_test(size=size) as pilot:
            app.query_one(MissionPanel).focus()
            await pilot.press("n")
            menu = await until(pilot, lambda: isinstance(app.screen, CommandMenu)
                               and app.screen, message="the command menu")
            assert menu.query_one(OptionList).option_count == 1
            await pilot.press("enter")
            form = await until(pilot, lambda: isinstance(app.screen, CommandForm)
                               and app.screen, message="the probe form")
            # the defaults are filled in; the labels say what to type
            assert form.values()["depth"] == "1" and form.values()["tool"] == "drill"
            labels = " ".join(str(w.render()) for w in form.query("Label"))
            assert "LAT,LON; LAT,LON; LAT,LON ..., at most 5 vertices" in labels
            assert "LAT,LON,RADIUS, radius 10 to 500 (m)" in labels
            for name, bad, message in MISTAKES:
                for key, text in GOOD.items():
                    form.query_one(f"#cmd-{key}", Input).value = bad if key == name else text
                await pilot.press("ctrl+s")
                assert isinstance(app.screen, CommandForm), name
                assert form.error.startswith(message), (form.error, message)
                assert app.focused is form.query_one(f"#cmd-{name}", Input)
            assert sent == [] and channel.sent == 0  # nothing went out
            for key, text in GOOD.items():
                form.query_one(f"#cmd-{key}", Input).value = text
            await pilot.press("ctrl+s")
            await until(pilot, lambda: len(sent) == 1, message="the good form sent")
        request = sent[0]
        assert request.command.name == "probe"
        assert request.command.literal(request.payload) == (
            "probe([47.07, 15.43], [[47.0, 15.0], [47.0, 15.01], [47.01, 15.01]], "
            "circle([47.07, 15.43], 100.0), 1.5, scoop, \"careful\")")
    run(body())


def test_escape_closes_a_form_and_sends_nothing(endpoints: BusEndpoints) -> None:
    async def body() -> None:
        app, channel = _app(endpoints, (80, 24))
        async with app.run_test(size=(80, 24)) as pilot:
            app.query_one(MissionPanel).focus()
            await pilot.press("n", "enter")
            await until(pilot, lambda: isinstance(app.screen, CommandForm), message="form")
            await pilot.press("escape")
            await until(pilot, lambda: not isinstance(app.screen, CommandForm),
                        message="closed")
            assert "probe not sent (form closed)" in app.query_one(OperatorBar).status_text
        assert channel.sent == 0
    run(body())


def test_a_declared_command_reaches_the_agent_and_its_refusal_shows_why(
        tuimission: Path) -> None:
    config = load_project("tuimission", HERE)
    mission = project_mission(config.directory, config.file, config.sections, tuimission)
    assert mission is not None and "exclusion" in mission.config.commands

    async def body() -> None:
        app = MrssApp(BusEndpoints.ipc(tuimission), project="tuimission", mind_every=0.3,
                      tree_every=0.5, mission=mission)
        async with app.run_test(size=(200, 50)) as pilot:
            panel = app.query_one(MissionPanel)
            mind = app.query_one("#mind")
            await until(pilot, lambda: getattr(mind, "snapshot", None) is not None,
                        timeout=30, message="the agent answers")

            async def exclusion(shape: str) -> CommandForm:
                panel.focus()
                await pilot.press("n")
                menu = await until(pilot, lambda: isinstance(app.screen, CommandMenu)
                                   and app.screen, message="the command menu")
                options = menu.query_one(OptionList)
                options.highlighted = [options.get_option_at_index(i).id
                                       for i in range(options.option_count)].index("exclusion")
                await pilot.press("enter")
                form = await until(pilot, lambda: isinstance(app.screen, CommandForm)
                                   and app.screen, message="the exclusion form")
                form.query_one("#cmd-shape", Input).value = shape
                await pilot.press("ctrl+s")
                return form

            # a self-intersecting zone stays in the form: the events manager sees nothing
            form = await exclusion("47,15; 47.01,15.01; 47.01,15; 47,15.01")
            assert "crosses itself" in form.error
            await pilot.press("escape")
            square = "47,15; 47,15.01; 47.01,15.01; 47.01,15"
            await exclusion(square)
            bar = app.query_one(OperatorBar)
            await until(pilot, lambda: "exclusion accepted" in bar.status_text, timeout=20,
                        message="the events manager accepted it")
            await until(pilot, lambda: "excluded(x1)" in " ".join(
                mind.snapshot.beliefs), timeout=20, message="the agent has it")
            # the same zone id again: the agent refuses it, with its reason, on the panel
            await exclusion("47,15; 47,15.02; 47.02,15.02; 47.02,15")
            await until(pilot, lambda: has_row(panel, "x1"), timeout=20,
                        message="x1 on the mission panel")
            row = row_text(panel, "x1")
            assert row[1] == "refused" and row[4] == "already_excluded", row
            await until(pilot, lambda: "agent: x1 refused: already_excluded"
                        in bar.status_text, message="the agent's answer said")
    run(body())
