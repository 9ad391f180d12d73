"""The project's operators (`secrets/operators.json`, made by `mrss users`), checked
before the system runs rather than at the first login.

- A project without the file has no users: nothing to check (one local operator).
- The file must load as the components load it (`mrss.auth.store.OperatorStore.load`):
  owned by this user, mode 0600, well-formed. A damaged file is an error at its line and
  column; a file open to others is an error with the chmod that fixes it. Either way
  every component would refuse everyone, so the mission could not be steered.
- Warnings: a user that has expired, a user with neither password nor token (cannot log
  in), no active commander (nobody may stop the system), and a project command
  (`[operator.commands.NAME] role`) that no active user's role may send.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

from mrss.auth.roles import Role
from mrss.auth.store import OperatorStore, store_path
from mrss.check.findings import Report
from mrss.check.toml_lines import key_line
from mrss.config.operator import OperatorConfig
from mrss.config.project import ProjectConfig
from mrss.errors import ConfigError

CHECK = "operators"


def check_operators(config: ProjectConfig, report: Report,
                    operator: OperatorConfig | None) -> None:
    """Findings for the project's identity store, if it has one."""
    path = store_path(config.directory)
    if not path.exists():
        return
    store = _load(path, report)
    if store is None:
        return
    now = time.time()
    file = str(path)
    folder = config.directory.name  # what `mrss users` is given
    active = [u for u in store.users.values() if not u.expired(now)]
    for user in sorted(store.users.values(), key=lambda u: u.name):
        if user.expired(now):
            ended = time.strftime("%Y-%m-%d %H:%M", time.localtime(user.expires))
            report.warning(file, f"user {user.name!r} ({user.role.value}) expired at "
                           f"{ended}: every command of theirs is refused; renew it with "
                           f"mrss users {folder} add {user.name} --role "
                           f"{user.role.value} --expires-days N, or remove it",
                           check=CHECK, key=f"users.{user.name}")
        if not user.password and not user.token:
            report.warning(file, f"user {user.name!r} has neither a password nor a token: "
                           "they cannot log in", check=CHECK, key=f"users.{user.name}")
    best = max((u.role.rank for u in active), default=-1)
    if best < Role.COMMANDER.rank:
        report.warning(file, "no active user is a commander: nobody may stop the system "
                       "or send commander-only commands; add one with mrss users "
                       f"{folder} add NAME --role commander", check=CHECK)
    for name, spec in sorted((operator.commands if operator else {}).items()):
        if spec.role in set(Role) and Role(spec.role).rank > best:
            key = f"operator.commands.{name}.role"
            report.warning(str(config.file), f"command {name!r} needs role {spec.role}, "
                           f"which no active user of {path.name} has: nobody may send it",
                           line=key_line(config, key), check=CHECK, key=key)
    roles = ", ".join(f"{sum(u.role is r for u in active)} {r.value}" for r in Role)
    report.summary.append(f"  operators: {len(active)} active ({roles})")


def _load(path: Path, report: Report) -> OperatorStore | None:
    """The store as the components load it; None with an error finding if refused."""
    try:
        return OperatorStore.load(path)
    except ConfigError as exc:
        line = col = 0
        try:
            json.loads(path.read_text(encoding="utf-8"))
        except json.JSONDecodeError as bad:
            line, col = bad.lineno, bad.colno
        except (OSError, UnicodeDecodeError):
            pass
        report.error(str(path), f"{exc.reason}; every component refuses every operator "
                     "until it is fixed", line=line, col=col, check=CHECK, key=exc.key)
        return None
