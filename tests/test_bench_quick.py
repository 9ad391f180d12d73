"""Every benchmark runs once in --quick mode so it doesn't rot (timings are not asserted)."""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
from collections.abc import Callable

import pytest

from mrss.bench import BENCHES
from mrss.testing import find_mosquitto
from tests.mosquitto import require_mosquitto

# The columns that compare us with another system, and the rows that must fill them:
# a report whose comparison is empty (the peer did not run) says nothing of what it is for.
COMPARISONS: dict[str, tuple[str, Callable[[str], bool]]] = {
    "bus": ("/ QoS 0", lambda row: not row.startswith("bus reliable")),  # vs MQTT QoS 0
    "reasoner": ("python-agentspeak 0.2.2", lambda row: row.startswith(("(a)", "(b)"))),
}
# what `mrss bench soak` must have sampled of the wildfire project
SOAK_PROCESSES = {"supervisor", "forkserver", "bus", "broker", "worldmodel", "datalayer",
                  "events", "sim_uav", "sim_ugv", "rcl", "reasoner"}
SOAK_FILES = {"mrss.log", "rcl-journal.sqlite3", "reasoner-percepts.sqlite3",
              "worldmodel.sqlite"}


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(BENCHES))
def test_benchmark_runs_in_quick_mode(name: str) -> None:
    assert importlib.util.find_spec(f"mrss.bench.{name}") is not None, \
        f"{name} is listed in mrss.bench.BENCHES but has no module"
    if name == "bus":  # its MQTT rows need Mosquitto (skipped, or failed on CI, without)
        require_mosquitto(find_mosquitto(), "the bus benchmark's MQTT comparison")
    out = subprocess.run([sys.executable, "-m", "mrss", "bench", name, "--quick", "--json"],
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    report = json.loads(out.stdout)
    assert report["name"] == name
    assert report["quick"] is True
    assert report["rows"], "a benchmark must report at least one row"
    assert all(len(row) == len(report["columns"]) for row in report["rows"])
    if name in COMPARISONS:
        column, compared = COMPARISONS[name]
        at = report["columns"].index(column)
        rows = [row for row in report["rows"] if compared(row[0])]
        empty = [row[0] for row in rows if not isinstance(row[at], (int, float))]
        assert rows and not empty, \
            f"no {column!r} for {empty or 'any row'}; notes: {report['notes']}"
    if name == "bus":
        assert {"MQTT QoS 0", "MQTT QoS 1"} <= {row[0] for row in report["rows"]}
    if name == "soak":  # every process under the root supervisor, and the run's files
        rows = {row[0]: row for row in report["rows"]}
        # the embedded broker runs Mosquitto where installed (engine = "auto"), sampled too
        processes = SOAK_PROCESSES | ({"broker/mosquitto"} if find_mosquitto() else set())
        assert rows.keys() >= processes | SOAK_FILES, sorted(rows)
        fds = report["columns"].index("fds start-end")
        assert all(isinstance(rows[n][fds], str) for n in processes)  # "20-20"
        size = report["columns"].index("MB end")
        assert all(isinstance(rows[n][size], float) for n in processes | SOAK_FILES)


@pytest.mark.slow
def test_e2e_under_load_reports_quiet_and_loaded_rows_of_one_run() -> None:
    out = subprocess.run([sys.executable, "-m", "mrss", "bench", "e2e", "--under-load",
                          "--quick", "--json"], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    report = json.loads(out.stdout)
    assert report["quick"] is True
    loads = [row[1] for row in report["rows"]]
    assert loads == ["quiet", "2 CPU hogs"] * 4  # e2e, restarts: shipped, then tuned
    assert [row[8] for row in report["rows"]] == ["shipped defaults"] * 4 + ["tuned (opt-in)"] * 4
    assert all(row[6] == 0 for row in report["rows"])  # nothing lost
    assert {t["target"] for t in report["targets"]} >= {
        "under load: e2e p99 within 2x the quiet p99",
        "under load: restart p99 within 2x the quiet p99"}
    # --under-load is refused for the other benchmarks, with the reason
    out = subprocess.run([sys.executable, "-m", "mrss", "bench", "bus", "--under-load"],
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 2 and "for e2e only" in out.stderr


def test_robots_option_is_for_the_fleet_benches_only_and_needs_two_robots() -> None:
    out = subprocess.run([sys.executable, "-m", "mrss", "bench", "bus", "--robots", "4"],
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 2 and "--robots is for fleet and allocation only" in out.stderr
    out = subprocess.run([sys.executable, "-m", "mrss", "bench", "fleet", "--robots", "1"],
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 2 and "at least 2" in out.stderr
