"""A component that refuses its configuration at start (a ConfigError in `start`) is
given up at once and not restarted: a restart would fail the same way (issue 15 item 5).
The reasoner refuses an agent program with load-time errors this way."""

from __future__ import annotations

import logging
from pathlib import Path

import pytest

from mrss.actors.reasoner.service import ReasonerComponent
from mrss.config.kinds import KINDS, ComponentKind
from mrss.errors import ConfigError
from mrss.runtime.component import ComponentContext
from mrss.supervision.children import ComponentStart
from mrss.supervision.reason import Cause, ExitReason
from mrss.supervision.spec import ChildSpec, OnExceeded
from tests.faults.conftest import MakeTree, worker


def test_a_config_error_at_start_is_given_up_without_restarts_or_retry(
        make_tree: MakeTree) -> None:
    tree = make_tree(worker("ok"), worker("bad", config_error_on_start=True), intensity=10,
                     on_exceeded=OnExceeded.QUARANTINE, probation=0.2, wait=False)
    (give_up,) = tree.log.wait_for("give_up", "bad", timeout=20)
    assert give_up.reason.startswith("config_error: project.toml: key 'components.bad': "
                                     "bad value")
    assert give_up.detail["retry_in"] is None  # never retried: fix it and start again
    assert give_up.detail["stops"] == "component"
    assert tree.log.of("restart", "bad") == []
    assert [e.reason for e in tree.log.of("exit", "bad")] == [give_up.reason]
    assert tree.sup.tree().find("bad").state == "quarantined"  # type: ignore[union-attr]
    assert tree.sup.ping("ok") and tree.sup.outcome is None  # the rest runs on


def test_with_stop_system_a_config_error_at_start_stops_the_system(
        make_tree: MakeTree) -> None:
    tree = make_tree(worker("ok"), worker("bad", config_error_on_start=True), intensity=10,
                     wait=False)
    outcome = tree.sup.wait(timeout=20)
    assert outcome is not None and outcome.gave_up and outcome.child == "bad"
    assert outcome.reason.startswith("config_error: ")
    assert tree.log.of("restart", "bad") == []


def test_a_reasoner_process_with_an_unloadable_program_is_refused_once(
        make_tree: MakeTree, tmp_path: Path) -> None:
    (tmp_path / "agent.asl").write_text("ok.\nb(X+1).\n")
    reasoner = ChildSpec("reasoner", ComponentStart(
        KINDS[ComponentKind.REASONER].target, {"agent": "agent.asl"}, 10.0))
    tree = make_tree(worker("ok"), reasoner, intensity=10, on_exceeded=OnExceeded.QUARANTINE,
                     probation=0.2, wait=False)
    (give_up,) = tree.log.wait_for("give_up", "reasoner", timeout=30)
    assert give_up.reason == (f"config_error: key 'agent': {tmp_path / 'agent.asl'}:2:1: "
                              "unbound variable X in arithmetic expression (X+1)")
    assert give_up.detail["retry_in"] is None
    assert tree.log.of("restart", "reasoner") == []
    log_lines = [line for line in (tmp_path / "mrss.log").read_text().splitlines()
                 if "start of reasoner failed" in line]
    assert len(log_lines) == 1 and f"{tmp_path / 'agent.asl'}:2:1:" in log_lines[0]


def test_exit_code_78_is_a_config_error_even_without_the_childs_word() -> None:
    assert ExitReason.from_returncode(78).cause is Cause.CONFIG_ERROR


@pytest.mark.parametrize(("program", "beliefs", "where"), [
    ("ok.\n+!g <- .print(1e400).\n", [], "agent.asl:2:15: number 1e400 is too large"),
    ("b(X+1).\n", [], "agent.asl:1:1: unbound variable X in arithmetic expression"),
    ("ok.\n", ["b(X+1)"], "beliefs:1:1: initial belief 'b(X+1)': unbound variable X"),
    ("ok(\"caf\xe9\").\n", [], "agent.asl:1:8: not UTF-8 text: byte 0xe9 at byte offset 7"),
])
def test_the_reasoner_refuses_a_program_that_does_not_load_in_one_line(
        tmp_path: Path, program: str, beliefs: list[str], where: str,
        caplog: pytest.LogCaptureFixture) -> None:
    (tmp_path / "agent.asl").write_bytes(program.encode("latin-1"))
    ctx = ComponentContext("reasoner", 1, tmp_path, tmp_path, options={"beliefs": beliefs})
    with caplog.at_level(logging.INFO), pytest.raises(ConfigError) as info:
        ReasonerComponent().start(ctx)
    message = str(info.value)
    assert "\n" not in message
    assert where in message
    assert not caplog.records  # refused before it started anything
