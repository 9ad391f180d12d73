"""Where a dotted key of project.toml is written: its line, for every finding about it."""

from __future__ import annotations

from mrss.config import ProjectConfig, key_line_number


def key_line(config: ProjectConfig, key: str) -> int:
    """The line of `key` (or of its table) in project.toml; 0 when it is not written there."""
    return key_line_number(config.file, key) or 0


def section_key(config: ProjectConfig, section: str, component: str | None, name: str) -> str:
    """The dotted key an edge option is written under: the component's table wins."""
    if component is not None:
        for comp in config.components:
            if comp.id == component and name in comp.options:
                return f"components.{component}.{name}"
    return f"{section}.{name}"

