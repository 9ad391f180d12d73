"""The identity store: a project's operators, their roles and their secrets, in one file.

Rules (the one place they are implemented):
- The store is `secrets/operators.json` in the project folder (`STORE_FILE`), made and
  changed by `mrss users PROJECT add|remove|list|set-role`. A project without it has no
  users configured: every command is accepted as before (one local operator).
- Each user has a role (`mrss.auth.roles.Role`), a password and/or a personal token,
  and may have an expiry (unix time, 0: never). Passwords are kept as Argon2 hashes
  (pwdlib); tokens (`mrss_` and 43 random characters, shown once when made) as SHA-256
  hashes: a token is random, so a fast hash is as safe as a slow one and is cheap to
  check on every HTTP request.
- The file also holds the session key (signs the dashboards' session credentials,
  `mrss.auth.sessions`) and the service token (the project's own clients' identity on
  the world model API when no `[worldmodel] token` is set).
- The file must belong to the user that reads it and be readable by that user only
  (mode 0600, as ssh wants of a private key): otherwise it is refused, with the chmod
  that fixes it, and nothing is accepted from anyone.
"""

from __future__ import annotations

import functools
import hashlib
import hmac
import json
import os
import re
import secrets
import stat
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from mrss.auth.roles import Role
from mrss.errors import ConfigError

STORE_FILE = "secrets/operators.json"
NAME = re.compile(r"[a-z][a-z0-9_.-]{0,31}")
TOKEN_PREFIX = "mrss_"
KEY_BYTES = 32
MIN_PASSWORD = 8


@dataclass(frozen=True)
class User:
    """One operator of the store (hashes only, never a secret in clear)."""

    name: str
    role: Role
    password: str = ""  # Argon2 hash, "" if none
    token: str = ""  # "sha256:<hex>", "" if none
    expires: float = 0.0  # unix time; 0: never

    def expired(self, now: float | None = None) -> bool:
        return bool(self.expires) and (now if now is not None else time.time()) >= self.expires

    def to_json(self) -> dict[str, Any]:
        return {"role": self.role.value, "password": self.password, "token": self.token,
                "expires": self.expires}


@dataclass(frozen=True)
class Identity:
    """Who an authenticated operator is."""

    name: str
    role: Role

    def __str__(self) -> str:
        return f"{self.name} ({self.role.value})"


class AuthError(Exception):
    """An identity that is refused: unknown, expired, a wrong secret. The text says why
    (never the secret)."""


def store_path(project_dir: Path) -> Path:
    return project_dir / STORE_FILE


def configured(project_dir: Path | None) -> bool:
    """Whether the project has users (its store exists)."""
    return project_dir is not None and store_path(project_dir).exists()


def token_digest(token: str) -> str:
    return "sha256:" + hashlib.sha256(token.encode()).hexdigest()


def _hasher() -> Any:
    from pwdlib import PasswordHash
    from pwdlib.hashers.argon2 import Argon2Hasher

    return PasswordHash((Argon2Hasher(),))


@dataclass(frozen=True)
class OperatorStore:
    """The store's content; `load` it, change it with the methods, `save` it."""

    path: Path
    key: bytes
    service_token: str
    users: dict[str, User] = field(default_factory=dict)

    # -- reading -------------------------------------------------------------------------
    @classmethod
    def new(cls, path: Path) -> OperatorStore:
        return cls(path, secrets.token_bytes(KEY_BYTES),
                   TOKEN_PREFIX + secrets.token_urlsafe(32))

    @classmethod
    def load(cls, path: Path) -> OperatorStore:
        """The store at `path` (ConfigError naming the file: missing, too open, damaged)."""
        try:
            st = path.stat()
        except OSError as exc:
            raise ConfigError(f"cannot read the operators file: {exc.strerror or exc}",
                              file=str(path)) from None
        check_private(path, st)  # at every load: a chmod does not change the content
        return _load(str(path), st.st_mtime_ns, st.st_size, st.st_ino)

    # -- who is who ------------------------------------------------------------------------
    def user(self, name: str) -> User:
        """The user `name` if known and not expired, else AuthError."""
        user = self.users.get(name)
        if user is None:
            raise AuthError(f"unknown user {name!r}")
        if user.expired():
            raise AuthError(f"user {name!r} expired at "
                            f"{time.strftime('%Y-%m-%d %H:%M', time.localtime(user.expires))}")
        return user

    def login(self, name: str, secret: str) -> Identity:
        """The identity of `name` whose password or token is `secret`; AuthError if not."""
        user = self.user(name)
        if user.token and hmac.compare_digest(user.token, token_digest(secret)):
            return Identity(user.name, user.role)
        if user.password and _hasher().verify(secret, user.password):
            return Identity(user.name, user.role)
        raise AuthError(f"wrong password or token for {name!r}")

    def by_token(self, token: str) -> Identity:
        """The identity whose personal token is `token`; AuthError if none."""
        digest = token_digest(token)
        for user in self.users.values():
            if user.token and hmac.compare_digest(user.token, digest):
                self.user(user.name)  # expired?
                return Identity(user.name, user.role)
        raise AuthError("unknown token")

    # -- changing ------------------------------------------------------------------------
    def with_user(self, name: str, role: Role, *, password: str | None = None,
                  token: str | None = None, expires: float | None = None) -> OperatorStore:
        """A store with `name` added or changed (ValueError for a bad name or password)."""
        if not NAME.fullmatch(name):
            raise ValueError(f"user name {name!r} must be 1 to 32 of a-z 0-9 _ . - "
                             "(starting with a letter)")
        if password is not None and len(password) < MIN_PASSWORD:
            raise ValueError(f"a password must have at least {MIN_PASSWORD} characters")
        old = self.users.get(name, User(name, role))
        user = replace(old, role=role,
                       password=_hasher().hash(password) if password is not None
                       else old.password,
                       token=token_digest(token) if token is not None else old.token,
                       expires=expires if expires is not None else old.expires)
        return replace(self, users={**self.users, name: user})

    def without_user(self, name: str) -> OperatorStore:
        if name not in self.users:
            raise ValueError(f"no user {name!r}{_did_you_mean(name, self.users)}")
        return replace(self, users={k: v for k, v in self.users.items() if k != name})

    def save(self) -> None:
        """Write the store atomically, readable by its owner only."""
        self.path.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
        data = {"version": 1, "key": self.key.hex(), "service_token": self.service_token,
                "users": {n: u.to_json() for n, u in sorted(self.users.items())}}
        partial = self.path.with_name(f".{self.path.name}.{os.getpid()}")
        fd = os.open(partial, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        with os.fdopen(fd, "w", encoding="utf-8") as out:
            json.dump(data, out, indent=1)
            out.write("\n")
        os.replace(partial, self.path)


def new_token() -> str:
    """A fresh personal token (shown once, stored hashed)."""
    return TOKEN_PREFIX + secrets.token_urlsafe(32)


def check_private(path: Path, st: os.stat_result | None = None) -> None:
    """ConfigError unless `path` is owned by this user and readable by nobody else."""
    st = st or path.stat()
    if st.st_uid != os.geteuid():
        raise ConfigError(f"the operators file belongs to uid {st.st_uid}, not to this user "
                          f"({os.geteuid()}): refused", file=str(path))
    if st.st_mode & 0o077:
        raise ConfigError(f"the operators file is open to others (mode "
                          f"{stat.S_IMODE(st.st_mode):04o}): refused; make it private with "
                          f"chmod 600 {path}", file=str(path))


@functools.lru_cache(maxsize=8)
def _load(path_text: str, mtime_ns: int, size: int, inode: int) -> OperatorStore:
    """The store at `path_text`, read again only when the file changed."""
    path = Path(path_text)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ConfigError(f"the operators file is damaged ({exc}); make it again with "
                          "mrss users", file=str(path)) from None
    try:
        users = {}
        for name, entry in data["users"].items():
            try:
                role = Role(entry["role"])
            except ValueError:
                raise ConfigError(f"role {entry['role']!r} is not one of "
                                  f"{', '.join(Role)}", file=str(path),
                                  key=f"users.{name}.role") from None
            users[name] = User(name, role, str(entry.get("password", "")),
                               str(entry.get("token", "")), float(entry.get("expires", 0)))
        return OperatorStore(path, bytes.fromhex(data["key"]), str(data["service_token"]),
                             users)
    except (KeyError, TypeError, AttributeError, ValueError) as exc:
        if isinstance(exc, ConfigError):
            raise
        raise ConfigError(f"the operators file lacks or has a bad {exc}; make it again with "
                          "mrss users", file=str(path)) from None


def _did_you_mean(name: str, names: Any) -> str:
    import difflib

    close = difflib.get_close_matches(name, list(names), n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""
