"""`mrss check`: prove a project consistent before anything starts (docs/projects.md).

`check_project(config)` runs every check of the package on a loaded project.toml and
returns a `Report`; nothing is started and no robot is connected. One module per kind
of check: `options` (every table's keys declared, typed and valid), `sources` (the
project's Python files: syntax, import, classes), `agent` (what agent.asl uses),
`recipes` (actions -> rcl.py recipes -> skills.py), `percepts` (events.py vs the
agent's triggers), `robots` (robot tables and link options); `runner` orders them and
suppresses the errors that only follow from another (no cascades).
"""

from mrss.check.findings import Finding, Report, Severity
from mrss.check.runner import check_project

__all__ = ["Finding", "Report", "Severity", "check_project"]
