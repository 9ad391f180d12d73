"""The reasoner benchmark's programs run correctly on our interpreter (tiny sizes; the
benchmark itself does the timing, tests never assert on it)."""

from __future__ import annotations

from mrss.bench import reasoner


def test_benchmark_programs_complete_on_our_interpreter() -> None:
    assert reasoner.ours_a(200) > 0
    assert reasoner.ours_b(200) > 0
    per_cycle, per_release = reasoner.ours_c(blocked=50, spin=100)
    assert per_cycle > 0 and per_release > 0
