"""A sample scope for a link under test (`RobotLink.set_sample_scope`): it records which
telemetry records were handed on inside which scope block, and which outside any."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any


class ScopeRecorder:
    """`scope` for `set_sample_scope`, `on_record` for the link's telemetry callback."""

    def __init__(self) -> None:
        self.scopes: list[list[str]] = []  # the record types of each finished block
        self.outside: list[str] = []  # record types handed on outside any block
        self._inside: list[list[str]] = []

    @contextmanager
    def scope(self) -> Iterator[None]:
        self._inside.append([])
        try:
            yield
        finally:
            self.scopes.append(self._inside.pop())

    def on_record(self, record: dict[str, Any]) -> None:
        (self._inside[-1] if self._inside else self.outside).append(str(record["type"]))
