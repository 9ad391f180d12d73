"""amqtt authentication plugins for the embedded broker: sessions kept, open or by password.

amqtt drops the session of an *anonymous* client when it disconnects, whatever its
clean_session flag says, so the events manager's persistent session (and the QoS 1
messages queued for it while it restarts) would be lost. This plugin accepts every
client, as the embedded broker always did (it listens on loopback unless configured),
without marking it anonymous. With a password file (`mrss.actors.broker.passwords`),
`PasswordFileAuthPlugin` lets in only the users of the file, also not as anonymous.
`mrss.actors.broker.service.broker_config` names the plugin; amqtt imports it.
"""

from __future__ import annotations

import asyncio
import dataclasses
from pathlib import Path
from typing import Any

from amqtt.plugins.base import BaseAuthPlugin

from mrss.actors.broker.passwords import log, password_hasher, read_users


class OpenSessionsAuthPlugin(BaseAuthPlugin):  # type: ignore[misc]
    """Accept every client; its session follows its own clean_session flag."""

    @dataclasses.dataclass
    class Config:
        """No options."""

    async def authenticate(self, *, session: Any) -> bool:
        return True


class PasswordFileAuthPlugin(BaseAuthPlugin):  # type: ignore[misc]  # untyped base
    """amqtt: a client in only with a user and password of the password file.

    Sessions are not marked anonymous, so persistent sessions are kept (as with
    `OpenSessionsAuthPlugin`).
    """

    @dataclasses.dataclass
    class Config:
        """The password file (an absolute path)."""

        password_file: str = ""

    def __init__(self, context: Any) -> None:
        super().__init__(context)
        self.users = read_users(Path(self.config.password_file))
        self.hasher = password_hasher()

    async def authenticate(self, *, session: Any) -> bool:
        user = getattr(session, "username", None)
        password = getattr(session, "password", None) or ""
        hashed = self.users.get(user) if user else None
        if hashed is None:
            log.warning("MQTT client %r refused: %s", getattr(session, "client_id", "?"),
                        f"unknown user {user!r}" if user else "no user name (anonymous)")
            return False
        loop = asyncio.get_running_loop()
        ok = await loop.run_in_executor(None, self._verify, password, hashed)
        if not ok:
            log.warning("MQTT client %r refused: wrong password for user %r",
                        getattr(session, "client_id", "?"), user)
        return bool(ok)

    def _verify(self, password: str, hashed: str) -> bool:
        try:
            return bool(self.hasher.verify(password, hashed))
        except Exception:  # a hash pwdlib cannot read: refuse, never crash the broker
            return False
