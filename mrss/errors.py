"""Exception types of MRSS; each carries the file, key, topic or uuid involved."""

from __future__ import annotations


class MrssError(Exception):
    """Base of every error MRSS raises on purpose."""


class DecodeError(MrssError):
    """A message from the bus or the outside could not be decoded or validated."""

    def __init__(self, reason: str, *, topic: str | None = None) -> None:
        self.reason = reason
        self.topic = topic
        where = f" on topic {topic!r}" if topic else ""
        super().__init__(f"cannot decode message{where}: {reason}")


class ConfigError(MrssError):
    """A configuration file is missing, malformed, or has a bad key."""

    def __init__(self, reason: str, *, file: str | None = None, key: str | None = None) -> None:
        self.reason = reason
        self.file = file
        self.key = key
        parts = [p for p in (file, f"key {key!r}" if key else None) if p]
        where = ": ".join(parts)
        super().__init__(f"{where}: {reason}" if where else reason)


class UnknownProjectError(MrssError):
    """A project name that has no folder under the projects directory."""

    def __init__(self, name: str, known: list[str]) -> None:
        self.name = name
        self.known = known
        listing = ", ".join(known) if known else "(none)"
        super().__init__(f"unknown project {name!r}; known projects: {listing}")


class BusError(MrssError):
    """The message bus could not deliver or was misconfigured."""


class SupervisionError(MrssError):
    """A supervisor gave up, or a child spec is invalid."""


class ActionError(MrssError):
    """An action could not be accepted, refined or transitioned."""

    def __init__(self, reason: str, *, uuid: str | None = None) -> None:
        self.reason = reason
        self.uuid = uuid
        super().__init__(f"action {uuid}: {reason}" if uuid else reason)


class TransientError(MrssError):
    """A failure worth another try: a dependency (the data layer, the world model, a
    restarting component) was away. Raised from a skill or `refine_action`, it fails the
    action with cause `transient`, which the agent's plans see as `error(transient)`."""
