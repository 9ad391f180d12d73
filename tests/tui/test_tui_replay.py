"""The dashboard in replay (`mrss tui --replay`), over a real recording of the wildfire
mission (tests/tui/wildfire_recording.py): seeking to the moment the hotspot was found
shows the UGV's dispatched action and the hotspot on the map; seeking back rebuilds the
state of that moment; the next-event keys, play, pause and speed."""

from __future__ import annotations

import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest

from mrss.commands.tui_replay import dashboard_settings
from mrss.messages import ActionRequest, ActionState, ActionStatus, Percept
from mrss.tui.models.alerts import AlertKind
from mrss.tui.replay.app import ReplayApp
from mrss.tui.replay.index import MarkKind
from mrss.tui.replay.player import PlayState
from mrss.tui.replay.tape import Tape
from mrss.tui.widgets.actions_table import ActionsTable
from mrss.tui.widgets.log_pane import LogPane
from mrss.tui.widgets.map_panel import MapPanel
from tests.tui.tui_helpers import row_text, run, until
from tests.tui.wildfire_recording import record_wildfire


@pytest.fixture(scope="module")
def wildfire_mcap(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """One recorded wildfire mission for the module's tests."""
    out = tmp_path_factory.mktemp("replay") / "wildfire.mcap"
    with tempfile.TemporaryDirectory(prefix="mrss-replay-") as run_dir:  # short ipc paths
        record_wildfire(out, Path(run_dir))
    yield out


def replay_app(path: Path, **kwargs: object) -> ReplayApp:
    tape = Tape.load(path)
    settings = dashboard_settings(None, tape.sections(), str(path))  # the recorded toml
    return ReplayApp(tape, name=path.name, project=tape.project, **settings,
                     **kwargs)  # type: ignore[arg-type]


def dispatch_of_the_hotspot(tape: Tape) -> tuple[float, float, ActionRequest]:
    """From the recording itself: when hs1 was found, and the action sent for it (asked
    of any UGV with water near hs1: the RCL's award names the robot)."""
    found = next(f.t for f in tape.frames if isinstance(f.env.body, Percept)
                 and f.env.body.literal.startswith("hotspot_detected(hs1,"))
    dispatch = next(f for f in tape.frames if isinstance(f.env.body, ActionRequest)
                    and f.env.body.goal == "hs1" and f.t >= found)
    assert isinstance(dispatch.env.body, ActionRequest)
    assert dispatch.env.body.robot == "" and \
        dispatch.env.body.role.get("capabilities") == ["ugv", "water"]
    return found, dispatch.t, dispatch.env.body


def award_of(tape: Tape, uuid: str) -> float:
    """When the RCL's first status named the robot the action went to (ugv1)."""
    return next(f.t for f in tape.frames if isinstance(f.env.body, ActionStatus)
                and f.env.body.uuid == uuid and f.env.body.robot == "ugv1")


@pytest.mark.slow
def test_seeking_to_the_hotspot_shows_the_ugv_dispatched_and_the_hotspot_on_the_map(
        wildfire_mcap: Path) -> None:
    app = replay_app(wildfire_mcap, play=False)
    found, dispatched, supply = dispatch_of_the_hotspot(app.tape)
    assert supply.name == "supply_water" and supply.goal == "hs1"

    async def body() -> None:
        async with app.run_test(size=(200, 55)) as pilot:
            table, panel = app.query_one(ActionsTable), app.query_one(MapPanel)
            assert app.player.state is PlayState.PAUSED and app.player.index == 0
            assert not app.map_model.objects and not app.actions.actions

            # W, W, ...: the next alert, until the hotspot's (other alerts may come first)
            for _ in range(20):
                await pilot.press("W")
                if app.player.time >= found:
                    break
            assert app.player.time == found
            assert any(a.kind == AlertKind.HOTSPOT and "hs1" in a.subject
                       for a in app.alerts.unacked())
            await until(pilot, lambda: "hs1" in app.map_model.objects,
                        message="hs1 on the map at the hotspot alert")

            # the moment the UGV was dispatched: its action, and the hotspot on the map
            app.seek_to(dispatched)
            await until(pilot, lambda: supply.uuid in table.shown_keys(),
                        message="the UGV's supply action in the actions table")
            assert "supply_water" in " ".join(row_text(table, supply.uuid))
            assert app.actions.actions[supply.uuid].state == "requested"  # just sent
            app.seek_to(award_of(app.tape, supply.uuid))   # awarded: the robot is known
            await until(pilot, lambda: "ugv1" in " ".join(row_text(table, supply.uuid)),
                        message="the supply's robot, ugv1, in the actions table")
            app.seek_to(dispatched)
            hs1 = app.map_model.objects["hs1"]
            assert hs1.kind == "hotspot" and hs1.point is not None
            assert abs(hs1.point[0] - -35.360387) < 1e-6 and abs(hs1.point[1] - 149.165678) < 1e-6
            await pilot.pause()
            assert "✹" in panel.render().plain  # the project's hotspot glyph, drawn

            # the end: the supply succeeded and the hotspot is supplied ...
            app.seek_to(app.player.end)
            assert app.actions.actions[supply.uuid].state == ActionState.SUCCEEDED
            assert app.map_model.objects["hs1"].attributes.get("state") == "supplied"
            assert app.player.state is PlayState.ENDED
            # ... and back at the dispatch, the state of that moment again
            app.seek_to(dispatched)
            assert app.actions.actions[supply.uuid].state != ActionState.SUCCEEDED
            assert app.map_model.objects["hs1"].attributes.get("state") != "supplied"
            lines = app.query_one(LogPane).lines_text()
            # the log as it was: the hotspot's alert (which caused the dispatch), not the
            # pumping that came after it
            assert any("alert hotspot: hotspot_detected(hs1" in line for line in lines)
            assert not any("pumping" in line for line in lines)
            assert app.player.state is PlayState.PAUSED

            # back to before anything: empty again
            app.seek_to(app.player.start - 100)
            assert supply.uuid not in app.actions.actions
            assert "hs1" not in app.map_model.objects
    run(body())


@pytest.mark.slow
def test_playing_feeds_the_dashboard_as_the_bus_would_and_pauses(wildfire_mcap: Path) -> None:
    app = replay_app(wildfire_mcap, play=False)
    found, _, supply = dispatch_of_the_hotspot(app.tape)

    async def body() -> None:
        async with app.run_test(size=(200, 55)) as pilot:
            app.seek_to(found - 1.0)
            assert supply.uuid not in app.actions.actions
            await pilot.press("greater_than_sign", "greater_than_sign")  # 1x -> 5x
            assert app.player.speed == 5.0
            await pilot.press("space")
            # playing; a loaded machine may play the few seconds left to the end before the
            # key returns (ended): both fed the dashboard
            assert app.player.state in (PlayState.PLAYING, PlayState.ENDED)
            # the same intake as on a live bus: the link is drained into the models
            await until(pilot, lambda: supply.uuid in app.actions.actions, timeout=30,
                        message="the dispatch reached by playing")
            assert app.replay_link.received > 0 and app.flushes > 0
            # a loaded machine may have played on to the end meanwhile (ended): back to
            # the start at 1x (the whole mission left to play, in its own time), playing,
            # so that space pauses a replay that plays
            await pilot.press("less_than_sign", "less_than_sign")  # 5x -> 1x
            assert app.player.speed == 1.0
            app.seek_to(app.player.start)
            if app.player.state is PlayState.PAUSED:
                await pilot.press("space")
            assert app.player.state is PlayState.PLAYING
            await pilot.press("space")
            assert app.player.state is PlayState.PAUSED
            paused_at = app.player.time
            app.step()  # what the step timer does: paused, the cursor stays
            assert app.player.time == paused_at and app.player.advance(60.0) == []
            assert "⏸ paused 1x" in app.timeline.plain
            await pilot.press("less_than_sign")
            assert app.player.speed == 0.5
            # the keys to the next event: no failure or restart in this mission
            await pilot.press("F")
            assert app.player.time == paused_at
            assert app.index.next_mark(MarkKind.RESTART, 0) is None
    run(body())
