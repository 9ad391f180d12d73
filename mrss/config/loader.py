"""Load and validate `projects/<name>/project.toml`: one place where config is checked.

Errors are `ConfigError`s naming the file (with the line when it can be found) and the
dotted key, e.g. `projects/demo/project.toml:12: key 'components.rcl.restart': ...`.
Tables this module does not know are kept raw in `ProjectConfig.sections` for the
layers that own them (robots, links, broker, ...). Every key is documented in
docs/config.md.

What a validated project is (`ProjectConfig` and its parts) is `mrss.config.project`;
how a component declares the options it reads, `mrss.options`; how a key's line is
found, `mrss.config.key_lines`. Their names are also importable from here.
"""

from __future__ import annotations

import math
import re
import tomllib
from collections.abc import Callable
from enum import StrEnum
from functools import partial
from pathlib import Path
from typing import Any, Literal, cast

from mrss.config.key_lines import key_line_number as key_line_number
from mrss.config.key_lines import line_of_key
from mrss.config.kinds import KINDS, ComponentKind, kind_of_target
from mrss.config.project import DEFAULT_RETRY_AFTER as DEFAULT_RETRY_AFTER
from mrss.config.project import ComponentConfig as ComponentConfig
from mrss.config.project import ConfigWarning as ConfigWarning
from mrss.config.project import ProjectConfig as ProjectConfig
from mrss.config.project import SupervisorConfig as SupervisorConfig
from mrss.config.projects import PROJECT_FILE, project_path
from mrss.errors import ConfigError, SupervisionError
from mrss.options import Check as Check
from mrss.options import Option as Option
from mrss.options import option_names as option_names
from mrss.supervision.spec import (
    KILL,
    Backoff,
    ChildKind,
    Group,
    OnExceeded,
    Restart,
    Strategy,
    SupervisorSpec,
)
from mrss.textfile import NotUtf8Error, read_text

ID_PATTERN = re.compile(r"^[A-Za-z][A-Za-z0-9_.-]*$")
TARGET_PATTERN = re.compile(r"^[A-Za-z_][\w.]*:[A-Za-z_]\w*$")
COMPONENT_KEYS = ("kind", "module", "child", "restart", "shutdown", "enabled", "start_timeout",
                  "backoff", "node", "nice", "cpus", "realtime")
SUPERVISOR_KEYS = ("strategy", "intensity", "period", "healthy_after", "on_give_up",
                   "retry_after", "shared_intensity", "groups", "heartbeat_interval",
                   "heartbeat_misses", "launcher", "run_dir", "backoff", "cpu_latency_us")
# [supervisor] keys of earlier versions, and what replaced them.
REPLACED_KEYS = {"on_exceeded": "on_give_up", "probation": "retry_after"}
NEVER = "never"
NICE_MIN, NICE_MAX = -20, 19


class OnGiveUp(StrEnum):
    """What the root does with a component (or group) that used up its restart budget."""

    STOP_COMPONENT = "stop_component"  # stop it, report it, keep the rest running
    STOP_SYSTEM = "stop_system"  # stop everything; `mrss supervise` exits 1

    @property
    def on_exceeded(self) -> OnExceeded:
        return OnExceeded.QUARANTINE if self is OnGiveUp.STOP_COMPONENT else OnExceeded.ESCALATE
# Tables owned by other layers: kept raw here; `mrss check` checks their keys.
OTHER_SECTIONS = ("nodes", "bus", "broker", "operator", "robots", "links", "reasoner", "rcl",
                  "events", "datalayer", "worldmodel", "tui", "sim", "skills", "alerts",
                  "map", "logs")


def load_project(name: str, base: Path | None = None) -> ProjectConfig:
    """Load projects/<name>/project.toml (UnknownProjectError if there is no such project)."""
    return load_file(project_path(name, base) / PROJECT_FILE)


def load_file(path: Path) -> ProjectConfig:
    """Load and validate one project.toml."""
    try:
        text = read_text(path)
    except OSError as exc:
        raise ConfigError(f"cannot read: {exc.strerror}", file=str(path)) from exc
    except NotUtf8Error as exc:
        raise ConfigError(f"line {exc.line}: {exc.reason}", file=str(path)) from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"not valid TOML: {exc}", file=str(path)) from exc
    return _Reader(path, text).project(data)


class _Reader:
    """Validation with the file's text at hand, to name the line of a bad key."""

    def __init__(self, path: Path, text: str) -> None:
        self.path = path
        self.lines = text.splitlines()
        self.warnings: list[ConfigWarning] = []

    def error(self, key: str, reason: str) -> ConfigError:
        line = self.line_of(key)
        where = f"{self.path}:{line}" if line else str(self.path)
        return ConfigError(reason, file=where, key=key)

    def line_of(self, key: str) -> int | None:
        """Best effort: the line of `key` under its table header, or of the header."""
        return line_of_key(self.lines, key)

    def project(self, data: dict[str, Any]) -> ProjectConfig:
        project = self.table(data, "project", ("name", "description"))
        name = self.typed(project, "project.name", str, self.path.parent.name)
        description = self.typed(project, "project.description", str, "")
        components = self.components(data)
        supervisor = self.supervisor(data, components)
        sections = {k: v for k, v in data.items()
                    if k not in ("project", "supervisor", "components")}
        # Unknown tables and misspelt keys are `mrss check`'s findings (the one place
        # they are judged; `mrss supervise` runs it first): loading stays quiet.
        return ProjectConfig(name=name, directory=self.path.parent, file=self.path,
                             description=description, supervisor=supervisor,
                             components=components, sections=sections,
                             warnings=tuple(self.warnings))

    def supervisor(self, data: dict[str, Any],
                   components: tuple[ComponentConfig, ...]) -> SupervisorConfig:
        raw = data.get("supervisor", {})
        for old, new in REPLACED_KEYS.items():
            if isinstance(raw, dict) and old in raw:
                raise self.error(f"supervisor.{old}", f"replaced by {new!r} "
                                 "(docs/config.md, [supervisor])")
        sup = self.table(data, "supervisor", SUPERVISOR_KEYS)
        raw_backoff = self.table(sup, "supervisor.backoff", ("initial", "factor", "cap", "jitter"),
                                 key="backoff")
        d = Backoff()
        backoff = self.build("supervisor.backoff", lambda: Backoff(
            initial=self.number(raw_backoff, "supervisor.backoff.initial", d.initial),
            factor=self.number(raw_backoff, "supervisor.backoff.factor", d.factor),
            cap=self.number(raw_backoff, "supervisor.backoff.cap", d.cap),
            jitter=self.number(raw_backoff, "supervisor.backoff.jitter", d.jitter)))
        s = SupervisorSpec()
        on_give_up = OnGiveUp(self.choice(sup, "supervisor.on_give_up", OnGiveUp,
                                          OnGiveUp.STOP_COMPONENT))
        shared = sup.get("shared_intensity")
        if shared is not None:
            shared = self.typed(sup, "supervisor.shared_intensity", int, 0)
            if shared < 0:
                raise self.error("supervisor.shared_intensity", "must be an integer >= 0")
        groups = self.groups(sup, components)
        spec = self.build("supervisor", lambda: SupervisorSpec(
            strategy=Strategy(self.choice(sup, "supervisor.strategy", Strategy, s.strategy)),
            intensity=self.typed(sup, "supervisor.intensity", int, s.intensity),
            period=self.number(sup, "supervisor.period", s.period),
            backoff=backoff,
            healthy_after=self.number(sup, "supervisor.healthy_after", s.healthy_after),
            on_exceeded=on_give_up.on_exceeded,
            probation=self.retry_after(sup),
            shared_intensity=shared,
            groups=groups))
        interval = self.number(sup, "supervisor.heartbeat_interval", 0.5)
        if interval <= 0:
            raise self.error("supervisor.heartbeat_interval", "must be > 0")
        misses = self.typed(sup, "supervisor.heartbeat_misses", int, 3)
        if misses < 1:
            raise self.error("supervisor.heartbeat_misses", "must be >= 1")
        launcher = self.typed(sup, "supervisor.launcher", str, "fork")
        if launcher not in ("fork", "exec"):
            raise self.error("supervisor.launcher", f"must be 'fork' or 'exec', not {launcher!r}")
        run_dir = self.typed(sup, "supervisor.run_dir", str, "") or None
        latency = None
        if "cpu_latency_us" in sup:
            latency = self.typed(sup, "supervisor.cpu_latency_us", int, 0)
            if latency < 0:
                raise self.error("supervisor.cpu_latency_us",
                                 f"must be a whole number of microseconds >= 0, not {latency}")
        return SupervisorConfig(spec, interval, misses,
                                cast(Literal["fork", "exec"], launcher), run_dir, latency)

    def retry_after(self, sup: dict[str, Any]) -> float:
        """`retry_after`: seconds >= 0, or "never" (a given-up component stays down)."""
        if sup.get("retry_after") == NEVER:
            return math.inf
        value = sup.get("retry_after", DEFAULT_RETRY_AFTER)
        if isinstance(value, bool) or not isinstance(value, int | float) \
                or not math.isfinite(value) or value < 0:
            raise self.error("supervisor.retry_after",
                             f"must be seconds >= 0 or {NEVER!r}, not {value!r}")
        return float(value)

    def groups(self, sup: dict[str, Any],
               components: tuple[ComponentConfig, ...]) -> tuple[Group, ...]:
        """`[supervisor.groups]`: name = [component ids], or name = { children = [...],
        intensity = N, period = S }; disabled components are left out."""
        raw = sup.get("groups", {})
        if not isinstance(raw, dict):
            raise self.error("supervisor.groups", "must be a table: name = [component ids]")
        known = {c.id: c for c in components}
        member_of: dict[str, str] = {}
        groups = []
        for name, value in raw.items():
            key = f"supervisor.groups.{name}"
            if not ID_PATTERN.match(name):
                raise self.error(key, "a group name starts with a letter and holds only "
                                      "letters, digits, '_', '-' and '.'")
            if isinstance(value, dict):  # the long form; unknown keys are errors
                table = self.table(raw, key, ("children", "intensity", "period"), key=name)
            else:
                table = {"children": value}
            members = table.get("children")
            intensity = self.typed(table, f"{key}.intensity", int, 1)
            period = self.number(table, f"{key}.period", 0.0) or None
            if not isinstance(members, list) or not members \
                    or not all(isinstance(m, str) for m in members):
                raise self.error(key, f"must be a non-empty list of component ids, "
                                      f"not {members!r}")
            for m in members:
                if m not in known:
                    hint = _close_to(m, tuple(known))
                    raise self.error(key, f"no component {m!r}" + (
                        f"; did you mean {hint!r}?" if hint else
                        f"; components: {', '.join(known)}"))
                if m in member_of:
                    raise self.error(key, f"component {m!r} is already in group "
                                          f"{member_of[m]!r}; a component belongs to one group")
                member_of[m] = name
            enabled = tuple(m for m in members if known[m].enabled)
            if enabled:
                groups.append(self.build(key, partial(Group, name, enabled, intensity, period)))
        return tuple(groups)

    def components(self, data: dict[str, Any]) -> tuple[ComponentConfig, ...]:
        raw = data.get("components", {})
        if not isinstance(raw, dict):
            raise self.error("components", "must be a table of [components.<id>] tables")
        result = []
        for cid, table in raw.items():
            key = f"components.{cid}"
            if not ID_PATTERN.match(cid):
                raise self.error(key, "a component id starts with a letter and holds only "
                                      "letters, digits, '_', '-' and '.'")
            if not isinstance(table, dict):
                raise self.error(key, "must be a table")
            kind, module, child = self.what_runs(table, key)
            shutdown = table.get("shutdown", 5.0)
            if shutdown != KILL and (isinstance(shutdown, bool)
                                     or not isinstance(shutdown, int | float) or shutdown < 0):
                raise self.error(f"{key}.shutdown", f"must be seconds >= 0 or 'kill', "
                                                    f"not {shutdown!r}")
            timeout = self.number(table, f"{key}.start_timeout", 10.0)
            if timeout <= 0:
                raise self.error(f"{key}.start_timeout", "must be > 0")
            result.append(ComponentConfig(
                id=cid, module=module, kind=kind,
                restart=Restart(self.choice(table, f"{key}.restart", Restart, Restart.PERMANENT)),
                shutdown=shutdown if shutdown == KILL else float(shutdown),
                child=child,
                enabled=self.typed(table, f"{key}.enabled", bool, True),
                start_timeout=timeout,
                backoff=self.typed(table, f"{key}.backoff", bool,
                                   kind is not ComponentKind.BUS),
                node=self.typed(table, f"{key}.node", str, ""),
                options={k: v for k, v in table.items() if k not in COMPONENT_KEYS},
                nice=self.nice(table, f"{key}.nice"), cpus=self.cpus(table, f"{key}.cpus"),
                realtime=self.realtime(table, f"{key}.realtime")))
        return tuple(result)

    def what_runs(self, table: dict[str, Any], key: str
                  ) -> tuple[ComponentKind | None, str, ChildKind]:
        """A component's kind (None for a project's own class), the class it starts and its
        child kind, from `kind` or `module` (config/kinds.py); former spellings warn."""
        kind_value, module = table.get("kind"), table.get("module")
        child = ChildKind(self.choice(table, f"{key}.child", ChildKind, ChildKind.WORKER))
        if kind_value in tuple(ChildKind):
            # Earlier releases' `kind` was the child kind; a shipped kind implies it now.
            known = kind_of_target(module) if isinstance(module, str) else None
            self.warn(f"{key}.kind", f"kind = {kind_value!r} is the former spelling of the "
                      "child kind", "drop it (the component's kind implies it)" if known
                      else f"child = {kind_value!r}")
            child, kind_value = ChildKind(kind_value), None
        if kind_value is not None:
            if module is not None:
                raise self.error(f"{key}.module", "give kind or module, not both: kind names a "
                                 "component MRSS ships, module a project's own class")
            kind = ComponentKind(self.choice(table, f"{key}.kind", ComponentKind, None))
            return kind, KINDS[kind].target, KINDS[kind].child
        if not isinstance(module, str) or not TARGET_PATTERN.match(module):
            raise self.error(f"{key}.kind" if module is None else f"{key}.module",
                             "required: kind = one of "
                             f"{', '.join(k.value for k in ComponentKind)} (a component MRSS "
                             "ships), or module = 'dotted.module:ClassName' (one of the "
                             "project's own)" + (f"; not module = {module!r}"
                                                 if module is not None else ""))
        former = kind_of_target(module)
        if former is None:
            return None, module, child
        self.warn(f"{key}.module", f"module = {module!r} names a class inside MRSS",
                  f"kind = {former.value!r}")
        return former, KINDS[former].target, KINDS[former].child

    def warn(self, key: str, what: str, instead: str) -> None:
        self.warnings.append(ConfigWarning(str(self.path), self.line_of(key) or 0, key, what,
                                           instead))

    # -- typed getters ----------------------------------------------------------------------
    def table(self, data: dict[str, Any], name: str, keys: tuple[str, ...],
              key: str | None = None) -> dict[str, Any]:
        value = data.get(key or name, {})
        if not isinstance(value, dict):
            raise self.error(name, "must be a table")
        for k in value:
            if k not in keys:
                hint = _close_to(k, keys)
                raise self.error(f"{name}.{k}", "unknown key" + (
                    f"; did you mean {hint!r}?" if hint else f"; known: {', '.join(keys)}"))
        return value

    def typed(self, data: dict[str, Any], key: str, kind: type, default: Any) -> Any:
        value = data.get(key.rsplit(".", 1)[-1], default)
        if kind is not bool and isinstance(value, bool) or not isinstance(value, kind):
            raise self.error(key, f"must be {kind.__name__}, not {value!r}")
        return value

    def nice(self, data: dict[str, Any], key: str) -> int | None:
        value = data.get("nice")
        if value is None:
            return None
        if isinstance(value, bool) or not isinstance(value, int) \
                or not NICE_MIN <= value <= NICE_MAX:
            raise self.error(key, f"must be a whole number from {NICE_MIN} (most favoured) to "
                                  f"{NICE_MAX}, not {value!r}")
        return value

    def realtime(self, data: dict[str, Any], key: str) -> int | None:
        value = data.get("realtime")
        if value is None:
            return None
        if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= 99:
            raise self.error(key, f"must be a real-time priority from 1 to 99, not {value!r}")
        return value

    def cpus(self, data: dict[str, Any], key: str) -> tuple[int, ...] | None:
        value = data.get("cpus")
        if value is None:
            return None
        if not isinstance(value, list) or not value or not all(
                isinstance(c, int) and not isinstance(c, bool) and c >= 0 for c in value):
            raise self.error(key, f"must be a non-empty list of CPU numbers (0, 1, ...), "
                                  f"not {value!r}")
        return tuple(sorted(set(value)))

    def number(self, data: dict[str, Any], key: str, default: float) -> float:
        value = data.get(key.rsplit(".", 1)[-1], default)
        if isinstance(value, bool) or not isinstance(value, int | float) or value < 0:
            raise self.error(key, f"must be a number >= 0, not {value!r}")
        return float(value)

    def choice(self, data: dict[str, Any], key: str, kind: Any, default: Any) -> str:
        value = data.get(key.rsplit(".", 1)[-1], default)
        options = [m.value for m in kind]
        if value not in options:
            hint = _close_to(value, tuple(options)) if isinstance(value, str) else None
            raise self.error(key, f"must be one of {', '.join(options)}, not {value!r}"
                             + (f"; did you mean {hint!r}?" if hint else ""))
        return str(value)

    def build(self, key: str, make: Callable[[], Any]) -> Any:
        try:
            return make()
        except SupervisionError as exc:
            raise self.error(key, str(exc)) from None


def _close_to(word: str, options: tuple[str, ...]) -> str | None:
    import difflib

    found = difflib.get_close_matches(word, options, n=1, cutoff=0.8)
    return found[0] if found else None
