"""What the project exposes: the world model's HTTP API and the embedded MQTT broker.

- `http_host` not a loopback address needs `token_file` or `token_env` in `[worldmodel]`
  (`mrss.edge.http_token`); both at once is an error; a `token_env` variable unset where
  `mrss check` runs is a warning (the world model refuses to start without it).
- `[broker.embedded] password_file` needs `[broker] username` (and a password): the
  project's own clients log in with them (`mrss.actors.broker.passwords`).
- A secret file (signing key, token, password file) others than its owner may read is a
  warning (`secret_mode_warning`).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from mrss.actors.broker.passwords import PASSWORD_FILE_KEY
from mrss.check.findings import Report
from mrss.check.toml_lines import key_line, section_key
from mrss.config.project import ProjectConfig
from mrss.edge.http_token import TOKEN_ENV_KEY, TOKEN_FILE_KEY, exposure_problem


def check_exposure(config: ProjectConfig, report: Report, table: Mapping[str, Any],
                   comp_id: str) -> None:
    """Findings for the world model's `http_host` and token keys (their values' own
    type and file checks are the options check's)."""
    if table.get("http", True) is False:
        return
    file_name, env_name = table.get(TOKEN_FILE_KEY), table.get(TOKEN_ENV_KEY)

    def where(name: str) -> tuple[str, int]:
        key = section_key(config, "worldmodel", comp_id, name)
        return key, key_line(config, key)

    warn_secret(config, report, where(TOKEN_FILE_KEY)[0], file_name, "token file")
    if file_name is not None and env_name is not None:
        key, line = where(TOKEN_ENV_KEY)
        report.error(str(config.file), f"give {TOKEN_FILE_KEY} or {TOKEN_ENV_KEY}, not both",
                     line=line, check="options", key=key)
    if isinstance(env_name, str) and env_name and env_name not in os.environ:
        key, line = where(TOKEN_ENV_KEY)
        report.warning(str(config.file), f"the environment variable {env_name} is not set "
                       "here; the world model will not start without it", line=line,
                       check="options", key=key)
    host = table.get("http_host", "127.0.0.1")
    if not isinstance(host, str):
        return
    problem = exposure_problem(host, file_name is not None or env_name is not None)
    if problem:
        host_key, _ = where("http_host")
        key, _ = where(TOKEN_FILE_KEY)
        report.error(str(config.file), problem, line=key_line(config, host_key),
                     check="options", key=key)


def check_broker_login(config: ProjectConfig, report: Report) -> None:
    """A password file for the embedded broker needs the project's own login."""
    broker = config.sections.get("broker", {})
    embedded = broker.get("embedded", {}) if isinstance(broker, Mapping) else {}
    if not isinstance(embedded, Mapping) or embedded.get(PASSWORD_FILE_KEY) is None \
            or broker.get("url"):
        return
    warn_secret(config, report, f"broker.embedded.{PASSWORD_FILE_KEY}",
                embedded.get(PASSWORD_FILE_KEY), "password file")
    missing = [k for k in ("username",) if not broker.get(k)]
    if not (broker.get("password") or broker.get("password_env")):
        missing.append("password_env")
    if missing:
        key = f"broker.embedded.{PASSWORD_FILE_KEY}"
        report.error(str(config.file), "the embedded broker only lets in the users of its "
                     "password file, and the project's own clients (events manager, MQTT "
                     "links, simulators) log in with [broker] username and password_env (or "
                     f"password): set {' and '.join(missing)}", line=key_line(config, key),
                     check="options", key=key)


def secret_mode_warning(path: Path, shown: str, what: str) -> str | None:
    """A warning when others than the owner may read a secret file (POSIX modes), or None."""
    try:
        mode = path.stat().st_mode
    except OSError:
        return None  # a missing file is the options check's error
    if mode & 0o077:
        return (f"{what} {shown!r} may be read by others than its owner (mode "
                f"{mode & 0o777:o}); chmod 600 it")
    return None


def warn_secret(config: ProjectConfig, report: Report, key: str, value: Any,
                what: str) -> None:
    """`secret_mode_warning` of a project-relative file named at `key`, as a finding."""
    if isinstance(value, str) and value:
        warning = secret_mode_warning(config.directory / value, value, what)
        if warning:
            report.warning(str(config.file), warning, line=key_line(config, key),
                           check="options", key=key)
