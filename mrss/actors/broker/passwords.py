"""Passwords for the embedded MQTT broker: the password file, its check, the amqtt plugin.

Rules (the one place they are implemented):
- `[broker.embedded] password_file` names a file in the project folder with one
  `user:hash` line per client (blank lines and `#` comments ignored), the hash an
  Argon2 one (`$argon2id$...`), as amqtt's own password files. Make a line with
  ``python -m mrss.actors.broker.passwords FILE USER`` (the password is read from stdin or
  asked for; the line is added, or replaces the user's).
- With a password file the embedded broker accepts only a client that logs in with a
  user of the file and its password: anonymous clients and wrong passwords are refused
  (CONNACK "not authorized"), logged at WARNING with the user name, never the password
  (`mrss.actors.broker.sessions.PasswordFileAuthPlugin`).
- The project's own clients log in with `[broker] username` and `password` /
  `password_env`: the events manager through `MqttSettings.from_config`, the MQTT robot
  links and the simulated UGV through the broker URL the run resolves
  (`mrss.links.connect.project_broker_url` adds the login), so `mrss check` requires a
  `username` when a password file is set.
"""

from __future__ import annotations

import argparse
import getpass
import logging
import sys
from pathlib import Path
from typing import Any

log = logging.getLogger("mrss.broker.auth")
PASSWORD_FILE_KEY = "password_file"
HASH_PREFIX = "$argon2"


def password_hasher() -> Any:
    """pwdlib's Argon2 hasher (imported only when passwords are used)."""
    from pwdlib import PasswordHash
    from pwdlib.hashers.argon2 import Argon2Hasher

    return PasswordHash((Argon2Hasher(),))


def hash_password(password: str) -> str:
    """The Argon2 hash of `password`, for a password file line."""
    return str(password_hasher().hash(password))


def read_users(path: Path) -> dict[str, str]:
    """user -> hash of a password file; ValueError naming the line when one is malformed."""
    users: dict[str, str] = {}
    text = path.read_text(encoding="utf-8")
    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        user, sep, hashed = line.partition(":")
        if not sep or not user or not hashed.startswith(HASH_PREFIX):
            raise ValueError(f"line {number} must be user:$argon2id$... (make it with python "
                             "-m mrss.actors.broker.passwords FILE USER)")
        users[user] = hashed
    if not users:
        raise ValueError("it names no user, so no client could log in")
    return users


def password_file_problem(path: Path, shown: str | None = None) -> str | None:
    """Why `path` is not a usable password file, or None (`shown`: its name in messages)."""
    name = shown or str(path)
    try:
        read_users(path)
    except OSError as exc:
        return f"cannot read password file {name!r}: {exc.strerror or exc}"
    except (UnicodeDecodeError, ValueError) as exc:
        return f"password file {name!r}: {exc}"
    return None


def add_user(path: Path, user: str, password: str) -> None:
    """Add `user` to the password file (replacing an earlier line of the same user)."""
    if not user or ":" in user or user.strip() != user:
        raise ValueError("a user name must be non-empty, without ':' or surrounding spaces")
    lines = path.read_text(encoding="utf-8").splitlines() if path.is_file() else []
    kept = [line for line in lines if line.partition(":")[0].strip() != user]
    kept.append(f"{user}:{hash_password(password)}")
    path.write_text("\n".join(kept) + "\n", encoding="utf-8")
    path.chmod(0o600)


def main(argv: list[str] | None = None) -> int:
    """``python -m mrss.actors.broker.passwords FILE USER``: add or replace a user's line."""
    parser = argparse.ArgumentParser(prog="python -m mrss.actors.broker.passwords",
                                     description="add a user to an embedded broker's "
                                                 "password file (password from stdin)")
    parser.add_argument("file", type=Path)
    parser.add_argument("user")
    args = parser.parse_args(argv)
    password = getpass.getpass(f"password for {args.user}: ") if sys.stdin.isatty() \
        else sys.stdin.readline().rstrip("\n")
    if not password:
        print("mrss.actors.broker.passwords: empty password", file=sys.stderr)
        return 2
    try:
        add_user(args.file, args.user, password)
    except (OSError, ValueError) as exc:
        print(f"mrss.actors.broker.passwords: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
