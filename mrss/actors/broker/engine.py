"""Which program is the embedded MQTT broker: `[broker.embedded] engine`.

"auto" (the default) is Mosquitto where it is installed and no password file is set (its
sessions persisted on disk, `mrss.actors.broker.mosquitto`), else amqtt (sessions in
memory only); "mosquitto" requires Mosquitto, "amqtt" always uses amqtt.
"""

from __future__ import annotations

from collections.abc import Mapping
from enum import StrEnum
from typing import Any

from mrss.errors import ConfigError

ENGINE_KEY = "broker.embedded.engine"


class BrokerEngine(StrEnum):
    """Which program is the embedded broker."""

    AUTO = "auto"  # Mosquitto where installed and no password file, else amqtt
    MOSQUITTO = "mosquitto"  # Mosquitto with persisted sessions (required)
    AMQTT = "amqtt"  # amqtt in the component's process, sessions in memory only


def broker_engine(wanted: str, password_file: str | None, binary: str | None
                  ) -> BrokerEngine:
    """The engine that serves: MOSQUITTO or AMQTT (never AUTO), given the configured one,
    the password file and the Mosquitto binary found (None: not installed); ConfigError
    naming the key when Mosquitto is asked for but cannot serve."""
    engine = BrokerEngine(wanted)
    if engine is BrokerEngine.AMQTT:
        return engine
    if engine is BrokerEngine.MOSQUITTO:
        if binary is None:
            raise ConfigError("mosquitto is not installed here (PATH, /usr/sbin); did you "
                              "mean engine = \"auto\"?", key=ENGINE_KEY)
        if password_file:
            raise ConfigError("Mosquitto cannot read the Argon2 password file: use engine "
                              "= \"amqtt\" with it, or an outside Mosquitto ([broker] url)",
                              key=ENGINE_KEY)
        return engine
    return BrokerEngine.MOSQUITTO if binary is not None and not password_file \
        else BrokerEngine.AMQTT


def table_of(config: Mapping[str, Any], *names: str) -> Mapping[str, Any]:
    """The nested table `config[names[0]][names[1]]...` ({} where absent or not a table)."""
    value: Any = config
    for name in names:
        value = value.get(name, {}) if isinstance(value, Mapping) else {}
    return value if isinstance(value, Mapping) else {}
