"""What the `open_store` fixture gives a test: a way to open the same store again."""

from __future__ import annotations

from collections.abc import Callable

from mrss.actors.worldmodel.store import WorldStore

StoreFactory = Callable[[], WorldStore]
