"""Every benchmark runs once in --quick mode so it doesn't rot (timings are not asserted)."""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys

import pytest

from mrss.bench import BENCHES


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(BENCHES))
def test_benchmark_runs_in_quick_mode(name: str) -> None:
    out = subprocess.run([sys.executable, "-m", "mrss", "bench", name, "--quick", "--json"],
                         capture_output=True, text=True, timeout=300)
    if importlib.util.find_spec(f"mrss.bench.{name}") is None:
        assert out.returncode == 2
        assert "not yet available" in out.stderr
        return
    assert out.returncode == 0, out.stderr
    report = json.loads(out.stdout)
    assert report["name"] == name
    assert report["quick"] is True
    assert report["rows"], "a benchmark must report at least one row"
    assert all(len(row) == len(report["columns"]) for row in report["rows"])
