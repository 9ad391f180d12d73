"""The world model HTTP API's bearer token: where it comes from and when it is required.

Rules (the one place they are implemented):
- The token is configured in `[worldmodel]` by exactly one of `token_file` (a file in
  the project folder holding the token; surrounding whitespace ignored) or `token_env`
  (the name of an environment variable holding it). A token is 16 to 512 visible ASCII
  characters without spaces (e.g. ``python -c "import secrets;
  print(secrets.token_urlsafe(32))"``).
- Serving beyond loopback (`http_host` not 127.0.0.0/8, ::1 or "localhost") needs a
  token: without one the world model refuses to start and `mrss check` reports it,
  naming `worldmodel.token_file`.
- With a token, every request must carry ``Authorization: Bearer <token>`` (401
  otherwise), on loopback too. A project with users (`mrss users`) has a token even
  without these keys: its identity store's service token; and an operator's own
  token or session credential is accepted too, for what the role allows (reads for
  every role, writes from operator up; 403 otherwise). The project's own clients
  (events manager adapters, the data layer, `mrss.api.WorldModelClient` built by them)
  send it by themselves.
"""

from __future__ import annotations

import hmac
import ipaddress
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from mrss.errors import ConfigError

TOKEN_FILE_KEY = "token_file"
TOKEN_ENV_KEY = "token_env"
MIN_LENGTH = 16
MAX_LENGTH = 512
SECTION = "worldmodel"


def token_text_problem(token: str, where: str) -> str | None:
    """Why `token` (read from `where`) is not a usable bearer token, or None."""
    if not MIN_LENGTH <= len(token) <= MAX_LENGTH:
        return (f"the token in {where} must be {MIN_LENGTH} to {MAX_LENGTH} characters, not "
                f"{len(token)} (e.g. python -c \"import secrets; "
                "print(secrets.token_urlsafe(32))\")")
    if not all(33 <= ord(c) <= 126 for c in token):
        return f"the token in {where} must be visible ASCII characters without spaces"
    return None


def token_file_problem(path: Path, shown: str | None = None) -> str | None:
    """Why `path` is not a usable token file, or None (`shown`: its name in messages)."""
    name = shown or str(path)
    try:
        text = path.read_text(encoding="ascii").strip()
    except UnicodeDecodeError:
        return f"the token in token file {name!r} must be visible ASCII characters"
    except OSError as exc:
        return f"cannot read token file {name!r}: {exc.strerror or exc}"
    return token_text_problem(text, f"token file {name!r}")


def is_loopback(host: str) -> bool:
    """Whether `host` only reaches this machine (127.0.0.0/8, ::1, localhost)."""
    if host.lower() == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False  # a host name or a wildcard: not provably loopback


def configured_token(section: Mapping[str, Any], project_dir: Path | None) -> str | None:
    """The `[worldmodel]` token (None when none is configured); ConfigError naming the key."""
    file_name = section.get(TOKEN_FILE_KEY)
    env_name = section.get(TOKEN_ENV_KEY)
    if file_name is not None and env_name is not None:
        raise ConfigError(f"give {TOKEN_FILE_KEY} or {TOKEN_ENV_KEY}, not both",
                          key=f"{SECTION}.{TOKEN_ENV_KEY}")
    if file_name is not None:
        if not isinstance(file_name, str) or not file_name:
            raise ConfigError("must be a file name in the project folder",
                              key=f"{SECTION}.{TOKEN_FILE_KEY}")
        path = Path(file_name)
        if project_dir is not None and not path.is_absolute():
            path = project_dir / path
        problem = token_file_problem(path, file_name)
        if problem:
            raise ConfigError(problem, key=f"{SECTION}.{TOKEN_FILE_KEY}")
        return path.read_text(encoding="ascii").strip()
    if env_name is not None:
        if not isinstance(env_name, str) or not env_name:
            raise ConfigError("must be the name of an environment variable",
                              key=f"{SECTION}.{TOKEN_ENV_KEY}")
        value = os.environ.get(env_name)
        if value is None:
            raise ConfigError(f"the environment variable {env_name} is not set",
                              key=f"{SECTION}.{TOKEN_ENV_KEY}")
        problem = token_text_problem(value.strip(), f"${env_name}")
        if problem:
            raise ConfigError(problem, key=f"{SECTION}.{TOKEN_ENV_KEY}")
        return value.strip()
    return service_token(project_dir)


def service_token(project_dir: Path | None) -> str | None:
    """A project with users (mrss.auth.store) and no token of its own: the store's
    service token, the project's own clients' identity; else None."""
    from mrss.auth.store import OperatorStore, configured, store_path

    if not configured(project_dir):
        return None
    assert project_dir is not None
    return OperatorStore.load(store_path(project_dir)).service_token


def project_token(project_dir: Path) -> str | None:
    """The world model token of the project in `project_dir` (its project.toml's
    `[worldmodel]`), or None; ConfigError naming the key when it cannot be read."""
    from mrss.config.loader import load_file
    from mrss.config.projects import PROJECT_FILE

    path = project_dir / PROJECT_FILE
    if not path.is_file():
        return None
    section = load_file(path).sections.get(SECTION, {})
    return configured_token(section if isinstance(section, Mapping) else {}, project_dir)


def exposure_problem(host: str, has_token: bool) -> str | None:
    """Why serving on `host` is refused (beyond loopback without a token), or None."""
    if has_token or is_loopback(host):
        return None
    return (f"http_host {host!r} is not a loopback address: the world model API would be "
            f"open to the network; set [{SECTION}] {TOKEN_FILE_KEY} = \"<file with a token>\" "
            f"(or {TOKEN_ENV_KEY} = \"<variable>\") so every request needs "
            "'Authorization: Bearer <token>', or serve on http_host = \"127.0.0.1\"")


def authorized(header: str | None, token: str | None) -> bool:
    """Whether an Authorization header value carries `token` (always, without a token)."""
    if token is None:
        return True
    if not header:
        return False
    scheme, _, value = header.strip().partition(" ")
    return scheme.lower() == "bearer" and hmac.compare_digest(value.strip().encode(),
                                                              token.encode())
