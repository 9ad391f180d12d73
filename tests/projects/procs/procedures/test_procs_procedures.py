"""Procedures of the `procs` test project: one passes, one fails on purpose."""

from __future__ import annotations

import os

from mrss.config.loader import load_project


def test_passing_procedure_loads_its_own_project() -> None:
    config = load_project(os.environ["MRSS_PROJECT"])
    assert config.name == "procs"
    assert str(config.directory) == os.environ["MRSS_PROJECT_DIR"]


def test_failing_procedure_fails_on_purpose() -> None:
    assert os.environ["MRSS_PROJECT"] == "not procs", "this procedure fails on purpose"
