"""quiet_gc: fewer, shorter garbage collections for a process that is the dashboard.

Painting allocates many short-lived objects (segments, styles, strips), so Python's
collector runs its young generation hundreds of times a second at 1,000 msgs/s and,
now and then, a full collection that walks every object of Textual's widget tree and
of the models: 0.1 to 0.5 s during which nothing is drawn (`mrss bench tui`: the p99
frames). After the screen is up, `quiet_gc` moves what exists (modules, widgets, CSS)
out of the collector's sight (`gc.freeze`) and collects the young generation after
20,000 allocations instead of 700. Process-wide: only `mrss tui`, whose process is the
dashboard, asks for it (`MrssApp(quiet_gc=True)`), not tests running apps in-process.
"""

from __future__ import annotations

import gc

THRESHOLDS = (20_000, 50, 50)  # young generation, then every 50 of the one before


def quiet_gc() -> None:
    gc.freeze()
    gc.set_threshold(*THRESHOLDS)
