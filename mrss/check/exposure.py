"""The world model's HTTP API: never open beyond loopback without a token.

`http_host` not a loopback address needs `token_file` or `token_env` in `[worldmodel]`
(`mrss.edge.http_token`); both at once is an error; a `token_env` variable unset where
`mrss check` runs is a warning (the world model refuses to start without it).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import Any

from mrss.check.findings import Report
from mrss.check.toml_lines import key_line, section_key
from mrss.config import ProjectConfig
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
