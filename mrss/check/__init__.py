"""`mrss check`: prove a project consistent before anything starts (docs/projects.md).

`check_project(config)` runs every check of the package on a loaded project.toml and
returns a `Report`; nothing is started and no robot is connected. One module per kind
of check: `options` (every table's keys declared, typed and valid), `sources` (the
project's Python files: syntax, import, classes), `agent` (what agent.asl uses),
`recipes` (actions -> rcl.py recipes -> skills.py), `percepts` (events.py vs the
agent's triggers), `robots` (robot tables and link options); `runner` orders them and
suppresses the errors that only follow from another (no cascades).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from mrss.check.findings import Finding, Report, Severity
    from mrss.check.runner import check_project

__all__ = ["Finding", "Report", "Severity", "check_project"]

# Exported lazily (PEP 562): the root supervisor reads `mrss.check.passed` without
# importing every check (and the code of every component they import).
_HOMES = {"Finding": "findings", "Report": "findings", "Severity": "findings",
          "check_project": "runner"}


def __getattr__(name: str) -> Any:
    home = _HOMES.get(name)
    if home is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f"{__name__}.{home}"), name)
