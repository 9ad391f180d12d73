"""The mind inspector's history: a ring buffer of the reasoner's snapshots.

Each entry is a snapshot that differed from the one before, with when it came and the
incarnation of the reasoner that sent it (a restarted reasoner starts a new one). A
cursor picks the entry shown: `None` follows the newest (live); stepping back or
freezing pins it to an entry (by its serial number, so it stays on the same snapshot
while new ones arrive and old ones fall out). `diff` compares an entry's beliefs with
the previous entry's. Nothing here knows Textual.
"""

from __future__ import annotations

import itertools
from collections import deque
from dataclasses import dataclass

from mrss.messages import MindSnapshot

HISTORY_LIMIT = 200


@dataclass(frozen=True)
class MindEntry:
    """One snapshot as received."""

    serial: int
    snapshot: MindSnapshot
    ts: float
    incarnation: int


class MindHistory:
    """Snapshots newest last; a cursor (None: live) over them."""

    def __init__(self, limit: int = HISTORY_LIMIT) -> None:
        self.entries: deque[MindEntry] = deque(maxlen=limit)
        self.cursor: int | None = None  # the serial pinned, None = the newest
        self._serials = itertools.count(1)

    def add(self, snapshot: MindSnapshot, ts: float, incarnation: int) -> bool:
        """Keep `snapshot` if it differs from the newest (or comes from another
        incarnation); whether it was kept."""
        if self.entries:
            last = self.entries[-1]
            if last.snapshot == snapshot and last.incarnation == incarnation:
                return False
        self.entries.append(MindEntry(next(self._serials), snapshot, ts, incarnation))
        if self.cursor is not None and self._index(self.cursor) is None:
            self.cursor = self.entries[0].serial  # the pinned one fell out: the oldest kept
        return True

    @property
    def live(self) -> bool:
        return self.cursor is None

    def _index(self, serial: int) -> int | None:
        for i, entry in enumerate(self.entries):
            if entry.serial == serial:
                return i
        return None

    def position(self) -> int:
        """The index of the entry shown (-1 when empty)."""
        if not self.entries:
            return -1
        if self.cursor is None:
            return len(self.entries) - 1
        index = self._index(self.cursor)
        return len(self.entries) - 1 if index is None else index

    def current(self) -> MindEntry | None:
        at = self.position()
        return self.entries[at] if at >= 0 else None

    def previous(self) -> MindEntry | None:
        at = self.position()
        return self.entries[at - 1] if at > 0 else None

    def back(self) -> bool:
        """One snapshot older (pins the cursor); False at the oldest."""
        at = self.position()
        if at <= 0:
            return False
        self.cursor = self.entries[at - 1].serial
        return True

    def forward(self) -> bool:
        """One snapshot newer; reaching the newest stays pinned there (frozen)."""
        at = self.position()
        if at < 0 or at >= len(self.entries) - 1:
            return False
        self.cursor = self.entries[at + 1].serial
        return True

    def freeze(self) -> None:
        """Pin the entry shown now: new snapshots are kept but not shown."""
        entry = self.current()
        self.cursor = entry.serial if entry is not None else None

    def follow(self) -> None:
        """Back to live: show each new snapshot as it comes."""
        self.cursor = None

    def diff(self, entry: MindEntry | None = None) -> tuple[list[str], list[str]]:
        """(added, removed) beliefs of `entry` (default: the one shown) against the
        entry before it; nothing for the first."""
        entry = entry or self.current()
        if entry is None:
            return [], []
        index = self._index(entry.serial)
        if not index:
            return [], []
        before = set(self.entries[index - 1].snapshot.beliefs)
        now = set(entry.snapshot.beliefs)
        return ([b for b in entry.snapshot.beliefs if b not in before],
                [b for b in self.entries[index - 1].snapshot.beliefs if b not in now])
