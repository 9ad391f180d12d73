"""What the edge components (events, data layer, world model) read of project.toml.

A component gets a `mrss.runtime.component.ComponentContext`. Its configuration is
the project's top-level tables (`[broker]`, `[events]`, `[datalayer]`, `[worldmodel]`
of project.toml) with the component's own free keys (`ctx.options`, from
`[components.<id>]`) laid over its table, so either place works.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from mrss.config.broker import table
from mrss.config.loader import load_file
from mrss.config.projects import PROJECT_FILE
from mrss.edge.record_declarations import configured_robots
from mrss.runtime.component import ComponentContext

EDGE_SECTIONS = ("broker", "events", "datalayer", "worldmodel")


def edge_config(ctx: ComponentContext, own_section: str) -> dict[str, Any]:
    """The edge tables of the project's configuration, `ctx.options` over `own_section`."""
    sections: dict[str, Any] = {}
    project_file = ctx.project_dir / PROJECT_FILE
    if project_file.is_file():
        sections = load_file(project_file).sections
    config = {name: dict(table(sections, name)) for name in EDGE_SECTIONS}
    config[own_section].update(ctx.options)
    return config


def project_robots(project_dir: Path) -> frozenset[str]:
    """The robots of a project: those of its RCLs' robots tables (empty without any)."""
    project_file = project_dir / PROJECT_FILE
    if not project_file.is_file():
        return frozenset()
    components = {c.id: c.options for c in load_file(project_file).components}
    return frozenset(configured_robots({"components": components}))
