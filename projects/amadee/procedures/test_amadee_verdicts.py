"""The verdict watcher: each expected goal's verdict is published once, an old one never."""

from __future__ import annotations

import json
import logging
from pathlib import Path
from typing import Any

import pytest

from mrss.api import WorldModelUnavailable, import_project_module
from mrss.api.testing import wait_until

watch_module = import_project_module(Path(__file__).resolve().parent.parent,
                                     "verdict_watch.py")


def test_a_new_verdict_is_published_once_and_an_old_one_is_not() -> None:
    world: dict[str, dict[str, Any]] = {
        "verdict_g1": {"attributes": {"legal": True, "action": "image(rover1,g1)"}}}
    sent: list[dict[str, Any]] = []
    watch = watch_module.VerdictWatch(world.get, lambda text: sent.append(json.loads(text)),
                                      interval=0.01)
    watch.start()
    try:
        watch.expect("g1")          # a request reusing goal g1: its old verdict is stale
        watch.expect("g2")
        world["verdict_g2"] = {"attributes": {"legal": False, "rule": "crew_safety",
                                              "detail": "crew 'eva1' ...",
                                              "action": "image(rover1,g2)"}}
        wait_until(lambda: sent, 5.0)
        world["verdict_g1"] = {"attributes": {"legal": False, "rule": "no_go_path",
                                              "action": "drive(rover1,g1,1.0,2.0)"}}
        wait_until(lambda: len(sent) == 2, 5.0)
        assert sent[0] == {"goal": "g2", "legal": False, "rule": "crew_safety",
                           "detail": "crew 'eva1' ...", "action": "image(rover1,g2)"}
        assert sent[1]["goal"] == "g1" and sent[1]["rule"] == "no_go_path"
        wait_until(lambda: not watch._pending, 5.0)   # both done: nothing sent again
        assert len(sent) == 2
    finally:
        watch.stop()


def test_a_world_model_that_is_down_is_waited_for_until_patience_runs_out(
        caplog: pytest.LogCaptureFixture) -> None:
    calls: list[str] = []

    def down(object_id: str) -> dict[str, Any] | None:
        calls.append(object_id)
        raise WorldModelUnavailable("the world model is not up")

    sent: list[str] = []
    # 1 s of patience at 10 ms: several polls even when a loaded machine stalls the thread
    watch = watch_module.VerdictWatch(down, sent.append, interval=0.01, patience=1.0,
                                      log=logging.getLogger("test.verdicts"))
    watch.start()
    try:
        with caplog.at_level(logging.WARNING, logger="test.verdicts"):
            watch.expect("g1")
            wait_until(lambda: not watch._pending, 5.0)
        assert len(calls) > 2 and not sent and watch._thread.is_alive()
        assert len(caplog.records) == 1, caplog.records   # one warning, not one per poll
        assert "the world model is not up" in caplog.records[0].getMessage()
    finally:
        watch.stop()
