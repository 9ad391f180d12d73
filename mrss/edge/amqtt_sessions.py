"""An amqtt authentication plugin for the embedded broker: everyone in, sessions kept.

amqtt drops the session of an *anonymous* client when it disconnects, whatever its
clean_session flag says, so the events manager's persistent session (and the QoS 1
messages queued for it while it restarts) would be lost. This plugin accepts every
client, as the embedded broker always did (it listens on loopback unless configured),
without marking it anonymous. `mrss.broker.broker_config` names it; amqtt imports it.
"""

from __future__ import annotations

import dataclasses
from typing import Any

from amqtt.plugins.base import BaseAuthPlugin


class OpenSessionsAuthPlugin(BaseAuthPlugin):  # type: ignore[misc]
    """Accept every client; its session follows its own clean_session flag."""

    @dataclasses.dataclass
    class Config:
        """No options."""

    async def authenticate(self, *, session: Any) -> bool:
        return True
