"""The replay's parts without a running system: recordings written here (MCAP and the
older format) of made-up missions; the player's table; seeking from keyframes gives the
state that applying every message from the start gives; the world rebuilt from writes;
the time a seek is typed as; bad files and options refused with a clear error."""

from __future__ import annotations

import dataclasses
import io
import itertools
import pickle
from pathlib import Path
from typing import Any

import pytest

from mrss.messages import (
    ActionRequest,
    ActionState,
    ActionStatus,
    DataReply,
    DataRequest,
    Envelope,
    Message,
    RobotData,
    SupEvent,
    SupEventKind,
    encode,
)
from mrss.recording.format import RecordedMessage, RecordingError, RecordingWriter
from mrss.recording.mcap_writer import McapRecordingWriter
from mrss.tui.replay.app import ReplayApp
from mrss.tui.replay.index import MarkKind, capture
from mrss.tui.replay.player import Player, PlayState
from mrss.tui.replay.seek_form import seek_target
from mrss.tui.replay.tape import Frame, Tape
from mrss.tui.replay.world import RecordedWorld, WorldChange
from mrss.world.topics import WM_REQUEST_TOPIC
from tests.commands.cli_bus import mrss
from tests.recording.test_mcap_bad_input import DAMAGES, good_recording
from tests.tui.tui_helpers import run

T0 = 1_700_000_000.0


def mission(count: int = 60) -> list[tuple[float, Message, str, str | None]]:
    """(time, message, sender, topic): two actions, one of them failing, a restart,
    telemetry, a hotspot written to the world model."""
    items: list[tuple[float, Message, str, str | None]] = []
    for i in range(count):
        t = T0 + i
        items.append((t, RobotData(robot="ugv1", data={"lat": 47.0 + i * 1e-4, "lon": 15.0,
                                                       "battery": 100 - i}), "rcl", None))
        if i == 5:
            items.append((t, ActionRequest(uuid="a1", name="go", args=[], robot="ugv1"), "reasoner",
                          None))
        if i == 8:
            items.append((t, ActionStatus(uuid="a1", state=ActionState.RUNNING, robot="ugv1",
                                          name="go"), "rcl", None))
        if i == 20:
            items.append((t, ActionStatus(uuid="a1", state=ActionState.FAILED, robot="ugv1",
                                          name="go", reason="stuck"), "rcl", None))
        if i == 30:
            items.append((t, SupEvent(event=SupEventKind.RESTART, child="rcl",
                                      reason="killed"), "root", None))
        if i == 40:
            items.append((t, DataRequest(request_id="w1", function="wm.upsert", args=[
                {"id": "hs1", "kind": "hotspot", "position": {"lat": 47.001, "lon": 15.0}}]),
                "datalayer", WM_REQUEST_TOPIC))
    return items


def write_mcap(path: Path, items: list[tuple[float, Message, str, str | None]]) -> None:
    with path.open("wb") as out:
        writer = McapRecordingWriter(out, created=T0)
        for t, body, src, topic in items:
            writer.write(RecordedMessage(t, encode(body, src=src, topic=topic)))
        writer.finish()


def comparable(app: ReplayApp) -> dict[str, Any]:
    """The models' state (a keyframe's), with counters by value; and the Messages
    screen's topics (recounted at each seek)."""
    state = pickle.loads(capture(app.intake.models))
    state["topics"] = {topic: (stats.count, [e.id for e in stats.recent])
                       for topic, stats in app.topics.topics.items()}
    return {name: {k: _value(v) for k, v in attributes.items()}
            for name, attributes in state.items()}


def _value(v: Any) -> Any:
    """A model attribute by value: counters by their repr, a model held by a model (the
    actions' tasks) by its attributes."""
    if isinstance(v, itertools.count):
        return repr(v)
    if hasattr(v, "__dict__") and not dataclasses.is_dataclass(v):
        return {k: _value(x) for k, x in vars(v).items()}
    return v


def test_a_seek_from_a_keyframe_gives_the_state_of_applying_everything_from_the_start(
        tmp_path: Path) -> None:
    path = tmp_path / "mission.mcap"
    write_mcap(path, mission())
    tape = Tape.load(path)
    assert tape.frames and tape.damage is None
    keyed = ReplayApp(tape, name="m", play=False, keyframe_every=7)
    plain = ReplayApp(tape, name="m", play=False, keyframe_every=10**9)
    assert len(keyed.index.keyframes) > 5 and len(plain.index.keyframes) == 1
    assert [(m.kind, m.t) for m in keyed.index.marks] == [
        (MarkKind.ACTION_FAILED, T0 + 20), (MarkKind.RESTART, T0 + 30),
        (MarkKind.ALERT, T0 + 30)]  # the restart's alert
    assert keyed.index.marks[0].text == "go on ugv1: stuck"
    assert keyed.index.marks == plain.index.marks

    async def body() -> None:
        async with keyed.run_test(size=(160, 50)), plain.run_test(size=(160, 50)):
            for t in (T0 + 45, T0 + 3, T0 + 21, T0 + 59, T0 + 30.5, T0 + 8):
                keyed.seek_to(t)
                plain.seek_to(t)
                assert comparable(keyed) == comparable(plain), t
            keyed.seek_to(T0 + 21)
            assert keyed.actions.actions["a1"].state == ActionState.FAILED
            keyed.seek_to(T0 + 10)
            assert keyed.actions.actions["a1"].state == ActionState.RUNNING
            assert "hs1" not in keyed.map_model.objects
            keyed.seek_to(T0 + 41)
            assert keyed.map_model.objects["hs1"].point == (47.001, 15.0)
    run(body())


def test_the_next_event_keys_seek_to_each_kind_in_turn(tmp_path: Path) -> None:
    path = tmp_path / "mission.mcap"
    write_mcap(path, mission())
    app = ReplayApp(Tape.load(path), name="m", play=False)

    async def body() -> None:
        async with app.run_test(size=(160, 50)) as pilot:
            await pilot.press("F")
            assert app.player.time == T0 + 20
            assert app.actions.actions["a1"].state == ActionState.FAILED
            await pilot.press("F")  # no other failure: the cursor stays, and says so
            assert app.player.time == T0 + 20
            await pilot.press("R")
            assert app.player.time == T0 + 30
            assert "↻" in app.timeline.plain and "✗" in app.timeline.plain
            await pilot.press("comma")
            assert app.player.time == T0 + 20
            await pilot.press("T")
            await pilot.press(*"0:45", "enter")
            assert app.player.time == T0 + 45
            await pilot.press("T")
            await pilot.press(*"soon", "enter")  # not a time: the form says so and stays
            assert "expected seconds" in str(app.screen.query_one("#seek-error").render())
            await pilot.press("escape")
            assert app.player.time == T0 + 45
    run(body())


def test_the_player_moves_by_its_table() -> None:
    frames = [Frame(T0 + i, Envelope("percept", f"m{i}", T0 + i, "x", 0,
                                     RobotData(robot="r", data={}))) for i in range(10)]
    player = Player(frames, speed=2.0)
    assert player.state is PlayState.PAUSED and player.advance(5) == []
    player.play()
    assert [e.id for e in player.advance(1.0)] == ["m0", "m1", "m2"]  # 2 s of recording
    assert player.index == 3
    assert len(player.advance(100)) == 7 and player.state is PlayState.ENDED
    assert player.seek_time(T0 + 4.5) == 5 and player.state is PlayState.PAUSED
    player.seek_time(T0 + 99)
    assert player.state is PlayState.ENDED and player.play() is True  # from the start
    assert [player.faster() for _ in range(4)] == [5.0, 10.0, 20.0, 20.0]
    assert [player.slower() for _ in range(6)][-2:] == [0.5, 0.5]
    with pytest.raises(ValueError, match="outside 0.5x to 20x"):
        Player(frames, speed=50)


def test_the_world_is_rebuilt_from_the_recorded_writes() -> None:
    world = RecordedWorld()

    def env(body: Message, topic: str = WM_REQUEST_TOPIC) -> Envelope:
        return Envelope(topic, "i", T0, "datalayer", 0, body)

    hs = {"id": "hs1", "kind": "hotspot", "position": {"lat": 1.0, "lon": 2.0},
          "attributes": {"t": 400}}
    assert world.apply(env(DataRequest("r1", "wm.upsert", [hs]))) is WorldChange.SHAPE
    assert world.apply(env(DataRequest("r2", "wm.upsert", [
        {"id": "hs1", "kind": "hotspot", "attributes": {"state": "supplying"}}]))) \
        is WorldChange.SHAPE
    assert world.objects["hs1"]["attributes"] == {"t": 400, "state": "supplying"}
    assert world.objects["hs1"]["position"] == {"lat": 1.0, "lon": 2.0}  # kept
    moved = {"id": "hs1", "kind": "hotspot", "position": {"lat": 1.5, "lon": 2.0}}
    assert world.apply(env(DataRequest("r3", "wm.upsert_many", [[moved]]))) \
        is WorldChange.POSITION
    stored = {**moved, "attributes": {"t": 400, "state": "supplied"}, "version": 4}
    assert world.apply(env(DataReply("r3", True, [{"op": "update", "object": stored}]),
                           "dl.reply.wm.datalayer")) is WorldChange.SHAPE
    assert world.objects["hs1"]["attributes"]["state"] == "supplied"
    assert world.apply(env(DataReply("r9", True, [{"op": "update", "object": {}}]),
                           "dl.reply.wm.x")) is WorldChange.NONE  # not a request it saw
    assert world.apply(env(DataRequest("r4", "wm.delete", ["hs1"]))) is WorldChange.SHAPE
    assert world.listing() == []


@pytest.mark.parametrize("text, expected", [
    ("90", T0 + 90), ("1:30", T0 + 90), ("1:00:05", T0 + 3605), ("+10", T0 + 110),
    ("-1:00", T0 + 40)])
def test_a_seek_is_typed_as_a_time_since_the_start_or_a_step(text: str,
                                                              expected: float) -> None:
    assert seek_target(text, start=T0, cursor=T0 + 100) == expected


@pytest.mark.parametrize("text", ["", "soon", "1::2", "-", "1:2:3:4", "nan"])
def test_a_seek_that_is_no_time_says_what_was_expected(text: str) -> None:
    with pytest.raises(ValueError, match="expected seconds or m:ss"):
        seek_target(text, start=T0, cursor=T0)


def test_the_older_format_and_damaged_files_load_up_to_the_damage(tmp_path: Path) -> None:
    old = io.BytesIO()
    writer = RecordingWriter(old, created=T0)
    for t, body, src, topic in mission(10):
        writer.write(RecordedMessage(t, encode(body, src=src, topic=topic)))
    (tmp_path / "old.mrssrec").write_bytes(old.getvalue())
    tape = Tape.load(tmp_path / "old.mrssrec")
    assert len([f for f in tape.frames if isinstance(f.env.body, RobotData)]) == 10

    data, ends = good_recording()
    for damage in DAMAGES:
        broken, offset, reason = damage(data, ends)
        path = tmp_path / f"{damage.__name__}.mcap"
        path.write_bytes(broken)
        if offset > 8:  # damage part way: what comes before it is kept
            tape = Tape.load(path)
            assert tape.damage is not None and tape.damage.offset == offset
            assert reason in tape.damage.reason
            assert len(tape.frames) == 20  # the two chunks before it
        else:
            with pytest.raises(RecordingError) as caught:
                Tape.load(path)
            assert caught.value.offset == offset and reason in caught.value.reason
            cli = mrss("tui", "--replay", str(path))
            assert cli.returncode == 2 and "Traceback" not in cli.stderr
            assert f"at byte offset {offset}: " in cli.stderr and reason in cli.stderr


def test_replay_options_are_checked_before_anything(tmp_path: Path) -> None:
    cli = mrss("tui", "--replay", str(tmp_path / "none.mcap"))
    assert cli.returncode == 2 and "cannot read" in cli.stderr and "none.mcap" in cli.stderr
    path = tmp_path / "m.mcap"
    write_mcap(path, mission(3))
    cli = mrss("tui", "--replay", str(path), "--speed", "50")
    assert cli.returncode == 2 and "--speed: speed 50 is outside 0.5x to 20x" in cli.stderr
    cli = mrss("tui")
    assert cli.returncode == 2 and "a project name is needed (or --replay FILE)" in cli.stderr
