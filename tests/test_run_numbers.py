"""The run number an incarnation key carries (mrss/messages/credentials.py): each new run
of a root in a kept run directory numbers above the last, even when the clock went back;
another node ranks every incarnation of a later run above every one of an earlier run."""

from __future__ import annotations

from pathlib import Path

import pytest

from mrss.errors import BusError, DecodeError
from mrss.messages import (
    RUN_SPAN,
    IncarnationKey,
    NodeBeat,
    across_runs,
    decode,
    encode,
    load_key,
    within_run,
)
from mrss.messages.credentials import KEY_FILE, MAX_RUN


def test_a_new_run_numbers_above_the_last_even_when_the_clock_went_back(
        tmp_path: Path) -> None:
    first = IncarnationKey.create(tmp_path, clock=lambda: 1_800_000_000.0)
    assert first.run == 1_800_000_000_000
    assert load_key(first.path) == first and load_key(first.path).run == first.run
    back = IncarnationKey.create(tmp_path, clock=lambda: 0.0)  # a clock reset to 1970
    assert back.run == first.run + 1 and back != first
    later = IncarnationKey.create(tmp_path, clock=lambda: 1_800_000_100.0)
    assert later.run == 1_800_000_100_000
    assert (tmp_path / KEY_FILE).stat().st_mode & 0o777 == 0o600


def test_a_key_file_of_an_older_release_reads_as_run_zero(tmp_path: Path) -> None:
    (tmp_path / KEY_FILE).write_bytes(b"k" * 32)
    assert load_key(str(tmp_path / KEY_FILE)).run == 0
    assert IncarnationKey.create(tmp_path, clock=lambda: 5.0).run == 5000
    (tmp_path / "bad").write_bytes(b"k" * 33)
    with pytest.raises(BusError, match="33 bytes"):
        load_key(str(tmp_path / "bad"))


def test_every_incarnation_of_a_later_run_ranks_above_the_earlier_runs() -> None:
    last, new = 1_800_000_000_000, 1_800_000_000_001
    assert across_runs(new, 1) > across_runs(last, RUN_SPAN - 1) > across_runs(last, 2)
    assert within_run(across_runs(new, 7)) == 7 and within_run(7) == 7
    assert across_runs(0, 3) == 3  # a node that numbers no runs: as it counts
    assert across_runs(new, 1) < 2**63  # signed 64 bits: SQLite and msgpack alike


@pytest.mark.parametrize("run", [-1, MAX_RUN + 1])
def test_a_node_beat_with_a_run_out_of_range_is_refused(run: int) -> None:
    with pytest.raises(DecodeError, match="run"):
        decode(*encode(NodeBeat(node="field", boot="b", run=run), src="node.field"))
