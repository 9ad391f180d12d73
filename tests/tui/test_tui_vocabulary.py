"""The percept line warns of a percept the project's agent never names or never reacts to."""

from __future__ import annotations

from pathlib import Path

from textual.widgets import Input

from mrss.bus import BusEndpoints
from mrss.config.loader import load_file
from mrss.messages import Percept
from mrss.tui.app import MrssApp
from mrss.tui.vocabulary import Reach, Vocabulary, project_agent_files
from mrss.tui.widgets.operator_bar import OperatorBar
from tests.tui.test_tui_panels import SIZE
from tests.tui.tui_helpers import Peer, connected, run, until

PROGRAM = """
robot(uav1).
busy(R) :- task(R, _).
+fire(A) : not busy(uav1) <- cover(uav1, A).
-fire(A) <- .print(A, " is out").
+battery_low(R) : task(R, G) & threshold(T) <- .suspend.
+!go(R) : wind(S) & S < 5 <- if (calm) { .print(ok) } else { .print(no) }.
"""


def vocabulary(tmp_path: Path) -> Vocabulary:
    (tmp_path / "agent.asl").write_text(PROGRAM)
    (tmp_path / "broken.asl").write_text("+fire( <- .")
    return Vocabulary.of_files([tmp_path / "agent.asl", tmp_path / "broken.asl",
                                tmp_path / "missing.asl"])


def test_what_the_program_reacts_to_reads_or_never_names(tmp_path: Path) -> None:
    v = vocabulary(tmp_path)
    assert v.reach("fire(a1)") is Reach.HANDLED
    assert v.reach("fire(a1)", remove=True) is Reach.HANDLED
    assert v.reach("battery_low(uav1)", remove=True) is Reach.USED  # only its addition
    for used in ("task(uav1, a1)", "threshold(3)", "wind(4)", "calm", "robot(uav2)"):
        assert v.reach(used) is Reach.USED, used
    assert v.warning("fire(a1)") == ""
    assert v.warning("wind(4)") == ("no plan reacts to +wind/1; the agent only has it as "
                                    "a belief")
    assert v.warning("fier(a1)") == ("the agent never names fier/1: no plan handles it "
                                     "(did you mean fire/1?)")
    assert v.warning("fire(a1, 2)").startswith("the agent never names fire/2")
    assert Vocabulary().warning("anything(1)") == ""  # no program known: no warnings


def test_the_agents_of_a_project_are_found_from_its_reasoners(tmp_path: Path) -> None:
    (tmp_path / "project.toml").write_text("""
name = "voc"
[components.reasoner]
kind = "reasoner"
agents = [{name = "a", file = "a.asl"}, {name = "b", file = "b.asl"}]
[components.other]
kind = "reasoner"
agent = "solo.asl"
[components.off]
kind = "reasoner"
enabled = false
agent = "off.asl"
""")
    for name in ("a", "b", "solo", "off"):
        (tmp_path / f"{name}.asl").write_text("+x <- true.\n")
    config = load_file(tmp_path / "project.toml")
    assert project_agent_files(config.components, config.directory) == [
        tmp_path / "a.asl", tmp_path / "b.asl", tmp_path / "solo.asl"]


def test_a_percept_no_plan_handles_is_sent_only_on_a_second_enter(
        endpoints: BusEndpoints, peer: Peer, tmp_path: Path) -> None:
    async def body() -> None:
        app = MrssApp(endpoints, project="demo", mind_every=0, tree_every=0,
                      vocabulary=vocabulary(tmp_path))
        async with app.run_test(size=SIZE) as pilot:
            await connected(pilot, peer)
            bar = app.query_one(OperatorBar)
            line = app.query_one("#percept", Input)
            await pilot.press("p")
            line.value = "fier(a1)"
            await pilot.press("enter")
            await until(pilot, lambda: "did you mean fire/1" in bar.status_text,
                        message="the warning")
            assert bar.status_error and line.value == "fier(a1)"  # kept, not sent
            line.value = "fire(a1)"  # fixed: handled, sent at once
            await pilot.press("enter")
            await until(pilot, lambda: len(peer.received(Percept)) == 1, message="sent")
            line.value = "wind(3)"  # only read in contexts: warned, then sent anyway
            await pilot.press("enter")
            await until(pilot, lambda: "only has it" in bar.status_text, message="warned")
            await pilot.press("enter")
            await until(pilot, lambda: len(peer.received(Percept)) == 2, message="sent anyway")
            assert peer.received(Percept) == [Percept(literal="fire(a1)"),
                                              Percept(literal="wind(3)")]
    run(body())
