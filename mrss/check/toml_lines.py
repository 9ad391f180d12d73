"""Where a dotted key of project.toml is written: its line, for every finding about it."""

from __future__ import annotations

from collections.abc import Callable
from typing import TypeVar

from mrss.check.findings import Report
from mrss.config.key_lines import key_line_number
from mrss.config.project import ProjectConfig
from mrss.errors import ConfigError

T = TypeVar("T")


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


def read_table(config: ProjectConfig, report: Report, section: str,
               read: Callable[..., T], *, title: str,
               line: Callable[[ProjectConfig, str], int] = key_line) -> T | None:
    """The project's `section` as `read(value, file=...)` makes it; None when the table is
    absent, or wrong: then an error naming its key, at that key's line."""
    if section not in config.sections:
        return None
    file = str(config.file)
    try:
        value: T = read(config.sections[section], file=file)
    except ConfigError as exc:
        key = exc.key or section
        report.error(file, f"{title}: {exc.reason}", line=line(config, key),
                     check=section, key=key)
        return None
    return value
