"""The options of the Foxglove component (`[components.<id>]` with `kind = "foxglove"`),
declared once: `mrss check` judges the table by them and the component reads through them."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from mrss.options import Check, Option, OptionValues

DEFAULT_PORT = 8765  # Foxglove's own default for a WebSocket connection

FOXGLOVE_OPTIONS: tuple[Option, ...] = (
    Option("host", str, "127.0.0.1", "address of the Foxglove WebSocket server: loopback "
           "only (it cannot authenticate its clients; reach it through an SSH tunnel)"),
    Option("port", int, DEFAULT_PORT, "its port (0: a free one; the URL is written to "
           "foxglove.url in the run folder)", Check.PORT),
    Option("prefixes", list, [""], "bus topics sent, by prefix (default: all of them)"),
    Option("backlog", int, 1024, "messages kept per client that reads slower than the "
           "bus sends (the oldest are dropped)", Check.POSITIVE),
)


def values_of(table: Mapping[str, Any], component: str) -> OptionValues:
    """The component's table read through the declaration."""
    return OptionValues(FOXGLOVE_OPTIONS, table, section=f"components.{component}")
