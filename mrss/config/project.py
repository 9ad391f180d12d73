"""A validated project.toml as plain data: what `mrss.config.loader` loading gives back.

`ProjectConfig` is the whole file: the project's name and folder, its `[supervisor]`
table (`SupervisorConfig`: the restart rules as a `SupervisorSpec`, plus how closely
processes are watched), its `[components.<id>]` tables (`ComponentConfig`s, in file
order) and the raw tables of other layers (`sections`). Every value here has passed
`mrss.config.loader`'s checks; a component's table becomes the root supervisor's `ChildSpec`
through `ComponentConfig.child_spec`, and only enabled components are children.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from mrss.config.kinds import ComponentKind
from mrss.supervision.children import ComponentStart, Scheduling
from mrss.supervision.spec import (
    ChildKind,
    ChildSpec,
    OnExceeded,
    Restart,
    SupervisorSpec,
)

DEFAULT_RETRY_AFTER = 60.0  # `[supervisor] retry_after`: seconds before a given-up retry


@dataclass(frozen=True)
class ConfigWarning:
    """A spelling of an earlier release that still works: where, and what to write now."""

    file: str
    line: int  # 0: not found
    key: str
    what: str
    instead: str

    def __str__(self) -> str:
        where = f"{self.file}:{self.line}" if self.line else self.file
        return f"{where}: {self.key}: {self.what}; write {self.instead}"


@dataclass(frozen=True)
class ComponentConfig:
    """One `[components.<id>]` table."""

    id: str
    module: str  # the class it starts, "dotted.module:Class" (its kind's, or the project's)
    kind: ComponentKind | None = None  # None: a project's own class
    restart: Restart = Restart.PERMANENT
    shutdown: float | Literal["kill"] = 5.0
    child: ChildKind = ChildKind.WORKER
    enabled: bool = True
    start_timeout: float = 10.0
    backoff: bool = True
    options: dict[str, Any] = field(default_factory=dict)
    node: str = ""  # the node it runs on (`[nodes]`, mrss.config.nodes); "" on a single host
    nice: int | None = None  # the process's nice value (-20..19); None: inherited
    cpus: tuple[int, ...] | None = None  # the CPUs it may run on; None: all
    realtime: int | None = None  # SCHED_RR priority 1..99; None: the normal scheduler

    def child_spec(self) -> ChildSpec[ComponentStart]:
        start = ComponentStart(self.module, dict(self.options), self.start_timeout,
                               Scheduling(self.nice, self.cpus, self.realtime))
        return ChildSpec(self.id, start, restart=self.restart, shutdown=self.shutdown,
                         kind=self.child, backoff=self.backoff)


@dataclass(frozen=True)
class SupervisorConfig:
    """The `[supervisor]` table: restart flags plus process-watching settings."""

    spec: SupervisorSpec = field(
        default_factory=lambda: SupervisorSpec(on_exceeded=OnExceeded.QUARANTINE,
                                               probation=DEFAULT_RETRY_AFTER))
    heartbeat_interval: float = 0.5
    heartbeat_misses: int = 3
    launcher: Literal["fork", "exec"] = "fork"
    run_dir: str | None = None
    cpu_latency_us: int | None = None  # held while the system runs (cpu_latency.py)


@dataclass(frozen=True)
class ProjectConfig:
    """A whole validated project.toml."""

    name: str
    directory: Path
    file: Path
    description: str = ""
    supervisor: SupervisorConfig = field(default_factory=SupervisorConfig)
    components: tuple[ComponentConfig, ...] = ()
    sections: dict[str, Any] = field(default_factory=dict)
    warnings: tuple[ConfigWarning, ...] = ()  # former spellings met while loading

    def child_specs(self) -> list[ChildSpec[ComponentStart]]:
        """The enabled components in file order: the root supervisor's children."""
        return [c.child_spec() for c in self.components if c.enabled]

    def enabled(self) -> tuple[ComponentConfig, ...]:
        return tuple(c for c in self.components if c.enabled)

    def of_kind(self, kind: ComponentKind) -> tuple[ComponentConfig, ...]:
        """The enabled components of one kind, in file order."""
        return tuple(c for c in self.components if c.enabled and c.kind is kind)
