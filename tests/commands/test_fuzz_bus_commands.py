"""Every command is total (issue 15 item 5): `mrss replay`, `mrss record` and `mrss send`
on a real bus, with seeded random recordings and extreme arguments, end with exit 0, 1 or
2 and a clear message, never a traceback, and within their own limits."""

from __future__ import annotations

import random
import subprocess
import sys
import time
from pathlib import Path

import msgpack
import pytest

from mrss.messages import Percept, encode
from mrss.recording.format import RecordedMessage, RecordingWriter
from tests.commands.cli_bus import ROOT, mrss, running_bus
from tests.commands.fuzz_inputs import (
    EXTREME_NUMBERS,
    argument,
    assert_total,
    block,
    random_bytes,
    recording,
    run_main,
    write,
)

SEED = 1516
ROUNDS = 30
FAST = ["--speed", "1000", "--max-gap", "0.05"]  # a hostile gap lasts 50 us at most


def _recorded(tmp_path: Path, times: list[float]) -> Path:
    path = tmp_path / "times.mrssrec"
    topic, payload = encode(Percept(literal="area(a1)"), src="fz")
    with path.open("wb") as f:
        writer = RecordingWriter(f, created=1.0)
        for t in times:
            writer.write(RecordedMessage(t, (topic, payload)))
    return path


@pytest.mark.timeout(300)
def test_replay_of_hostile_recordings_is_total(tmp_path: Path) -> None:
    rng = random.Random(SEED)
    with running_bus() as bus:
        for i in range(ROUNDS):
            data = recording(rng) if rng.randrange(4) else random_bytes(rng)
            path = write(tmp_path / f"r{i}.mrssrec", data)
            pace = rng.choice([FAST, ["--as-fast-as-possible"], ["--max-gap", "0"]])
            argv = ["replay", str(path), "--run-dir", str(bus.run_dir), *pace]
            outcome = run_main(argv)
            assert_total(outcome, argv)


@pytest.mark.timeout(300)
def test_replay_with_extreme_arguments_is_total(tmp_path: Path) -> None:
    rng = random.Random(SEED + 1)
    with running_bus() as bus:
        path = _recorded(tmp_path, [1.0, 2.0])
        for _ in range(ROUNDS):
            argv = ["replay", str(path), "--run-dir", str(bus.run_dir), "--max-gap", "0.01"]
            option = rng.choice(["--speed", "--max-gap", "--timeout", "--prefix"])
            argv += [option, rng.choice(EXTREME_NUMBERS) if rng.randrange(3) else argument(rng)]
            outcome = run_main(argv)
            assert_total(outcome, argv)


def test_replay_rejects_speeds_outside_its_range(tmp_path: Path) -> None:
    path = _recorded(tmp_path, [1.0])
    for speed in ("1e-300", "1e300", "0", "-1", "nan", "inf"):
        outcome = run_main(["replay", str(path), "--run-dir", str(tmp_path), "--speed", speed])
        assert outcome.code == 2
        assert f"'{speed}' is outside [0.001, 1000]" in outcome.err


def test_replay_bounds_recorded_gaps_and_skips_bad_times(tmp_path: Path) -> None:
    """A forged entry at 1e300 s (valid checksum) and one a billion seconds on are each
    replayed after --max-gap; a negative time is skipped as undecodable."""
    now = time.time()
    path = _recorded(tmp_path, [now, 1e300, now + 1e9, now])
    with path.open("ab") as f:
        f.write(block(msgpack.packb([-5.0, [b"percept", b"x"], ""], use_bin_type=True)))
    with running_bus() as bus:
        argv = ["replay", str(path), "--run-dir", str(bus.run_dir), "--max-gap", "0.1"]
        outcome = run_main(argv)
    assert outcome.code == 0, outcome.err
    assert "replayed 4 messages" in outcome.out
    assert "entry time is not a finite float >= 0" in outcome.err


@pytest.mark.timeout(300)
def test_send_with_extreme_arguments_is_total() -> None:
    rng = random.Random(SEED + 2)
    kinds = [["percept", "LIT"], ["percept", "LIT", "--remove"], ["control", "cancel", "ARG"],
             ["control", "ARG", "ARG"], ["teleop", "ARG", "on"], ["command", "ARG",
             "--arg", "ARG"], ["raw", "ARG", "ARG"], ["raw", "percept", "JSON"],
             ["command", "ARG", "--target", "ARG"]]
    jsons = ['{"literal": "a(1e400)"}', '{"literal": 1e400}', "{", "[]", '{"literal": "a"}',
             '{"x": ' * 5000 + "1" + "}" * 5000, '"\\ud800"', "NaN", '{"literal": "' + "a(" * 400 +
             '"}']
    with running_bus() as bus:
        for _ in range(ROUNDS * 2):
            words = [w if w not in ("LIT", "ARG", "JSON") else
                     rng.choice(jsons) if w == "JSON" else
                     rng.choice(["area(a1)", "a(1e400)", argument(rng)]) for w in rng.choice(kinds)]
            argv = ["send", "--run-dir", str(bus.run_dir), "--timeout",
                    rng.choice(["2", "0.5", *EXTREME_NUMBERS]), *words]
            outcome = run_main(argv)
            assert_total(outcome, argv)


@pytest.mark.timeout(300)
def test_record_with_extreme_arguments_is_total(tmp_path: Path) -> None:
    rng = random.Random(SEED + 3)
    with running_bus() as bus:
        for i in range(ROUNDS // 2):
            out = rng.choice([str(tmp_path / f"o{i}.mrssrec"), str(tmp_path), "/nonexistent/x",
                              str(tmp_path / ("n" * 300))])
            argv = ["record", "--run-dir", str(bus.run_dir), "--out", out,
                    "--duration", rng.choice(["0.05", *EXTREME_NUMBERS]),
                    "--timeout", rng.choice(["2", *EXTREME_NUMBERS])]
            if rng.randrange(2):
                argv += ["--prefix", argument(rng)]
            outcome = run_main(argv)
            assert_total(outcome, argv)


def test_bus_commands_without_a_bus_say_so_as_processes(tmp_path: Path) -> None:
    """As real processes: no bus within the timeout is a one-line error and exit 2."""
    path = _recorded(tmp_path, [1.0, 1e300])
    for args in (["replay", str(path)], ["record", "--duration", "1"],
                 ["send", "percept", "area(a1)"]):
        done = mrss(*args, "--run-dir", str(tmp_path), "--timeout", "0.2")
        assert done.returncode == 2, done.stderr
        assert "Traceback" not in done.stderr
        assert "no bus" in done.stderr, done.stderr


@pytest.mark.parametrize(("text", "reason"), [
    ('{"literal": 1e400}', "number 1e400 is too large for a float"),
    ('{"literal": NaN}', "NaN is not a JSON number"),
    ('{"x": ' * 5000 + "1" + "}" * 5000, "nested too deeply"),
    ('{"literal": ' + "9" * 400 + "}", "number 999999999999999999999999... is too large"),
])
def test_send_rejects_json_that_python_would_take_or_crash_on(text: str, reason: str) -> None:
    argv = ["send", "--run-dir", "/nonexistent", "raw", "percept", text]
    outcome = run_main(argv)
    assert outcome.code == 2
    assert f"JSON is not valid: {reason}" in outcome.err


def test_arguments_that_are_not_utf8_are_refused_by_every_command(tmp_path: Path) -> None:
    """Bytes that are not UTF-8 in argv (a Latin-1 shell) are one clear error, exit 2."""
    for verb in (["agent", b"\xff.asl"], ["check", b"\xff"], ["record", "--prefix", b"\xff"],
                 ["replay", b"r\xe9.mrssrec"], ["send", "percept", b"a\xff"]):
        done = subprocess.run([sys.executable, "-m", "mrss", *verb], cwd=ROOT,
                              capture_output=True, timeout=60)
        assert done.returncode == 2, done.stderr
        assert b"is not UTF-8 text" in done.stderr and b"Traceback" not in done.stderr
