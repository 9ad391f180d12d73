"""Build a robot link from its kind and options, as a project's configuration gives them."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from mrss.errors import ConfigError
from mrss.links.base import LinkStateCallback, RobotLink, TelemetryCallback
from mrss.links.failsafe import FAILSAFE_KEY, TIMEOUT_KEY, failsafe_problems, policy_of
from mrss.links.http import HttpLink
from mrss.links.mavlink import MavlinkLink
from mrss.links.mavlink_signing import load_key
from mrss.links.mqtt import MqttLink

# Per kind: option name -> (type, required). Names match the link constructors, but for
# the failsafe keys of every kind, which become one `failsafe` policy (mrss.links.failsafe).
_FAILSAFE_OPTIONS: dict[str, tuple[type, bool]] = {FAILSAFE_KEY: (str, False),
                                                   TIMEOUT_KEY: (float, False)}
LINK_OPTIONS: dict[str, dict[str, tuple[type, bool]]] = {
    "mavlink": {"url": (str, True), "target_system": (int, False),
                "heartbeat_timeout": (float, False), "command_timeout": (float, False),
                "retries": (int, False), "progress_timeout": (float, False),
                "signing_key": (str, False), **_FAILSAFE_OPTIONS},
    "mqtt": {"broker_url": (str, True), "prefix": (str, False),
             "telemetry_timeout": (float, False), "command_timeout": (float, False),
             "retries": (int, False), "keepalive": (int, False), "username": (str, False),
             "password_file": (str, False), "ca_certs": (str, False), "certfile": (str, False),
             "keyfile": (str, False), **_FAILSAFE_OPTIONS},
    "http": {"url": (str, True), "poll": (float, False), "timeout": (float, False),
             "command_timeout": (float, False), "retries": (int, False), **_FAILSAFE_OPTIONS},
}


def _range_problem(name: str, value: Any) -> str:
    """What is wrong with a well-typed option value ("" if nothing): durations must be
    positive, counts not negative, a MAVLink system id in 1..255."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        return ""
    if (name.endswith("timeout") or name in ("poll", "keepalive")) and not value > 0:
        return f"must be a positive number of seconds, got {value!r}"
    if name == "retries" and value < 0:
        return f"must be 0 or more, got {value!r}"
    if name == "target_system" and not 1 <= value <= 255:
        return f"must be a MAVLink system id in 1..255, got {value!r}"
    return ""


def option_value_problems(options: Mapping[str, Any]) -> list[tuple[str, str]]:
    """(key, problem) for option values a type check lets through (a misspelt failsafe,
    a zero or negative duration, a negative count)."""
    ranges = [(k, why) for k, v in options.items() if (why := _range_problem(k, v))]
    return ranges + failsafe_problems(options)


def _checked(kind: str, options: Mapping[str, Any], source: str | None) -> dict[str, Any]:
    spec = LINK_OPTIONS[kind]
    unknown = sorted(set(options) - set(spec))
    if unknown:
        raise ConfigError(f"unknown {kind} link option(s) {', '.join(unknown)}; "
                          f"known: {', '.join(spec)}", file=source, key=unknown[0])
    checked: dict[str, Any] = {}
    for name, (kind_type, required) in spec.items():
        if name not in options:
            if required:
                raise ConfigError(f"{kind} link needs {name!r}", file=source, key=name)
            continue
        value = options[name]
        if kind_type is float and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        if not isinstance(value, kind_type) or isinstance(value, bool):
            raise ConfigError(f"{name!r} must be of type {kind_type.__name__}, got {value!r}",
                              file=source, key=name)
        problem = _range_problem(name, value)
        if problem:
            raise ConfigError(f"{name!r} {problem}", file=source, key=name)
        checked[name] = value
    return checked


def create_link(robot_id: str, kind: str, options: Mapping[str, Any], *,
                on_link_state: LinkStateCallback | None = None,
                on_telemetry: TelemetryCallback | None = None,
                source: str | None = None) -> RobotLink:
    """A (not yet started) link of `kind` ("mavlink", "mqtt", "http"); ConfigError if not valid.

    `source` names the configuration file in error messages.
    """
    if kind not in LINK_OPTIONS:
        raise ConfigError(f"unknown link kind {kind!r}; known: {', '.join(LINK_OPTIONS)}",
                          file=source, key="link")
    checked = _checked(kind, options, source)
    failsafe = policy_of(checked, source=source)
    checked.pop(FAILSAFE_KEY, None)
    checked.pop(TIMEOUT_KEY, None)
    if kind == "mavlink":
        if "signing_key" in checked:
            try:
                checked["signing_key"] = load_key(checked["signing_key"])
            except ConfigError as exc:
                raise ConfigError(exc.reason, file=source, key=exc.key) from None
        return MavlinkLink(robot_id, on_link_state=on_link_state, on_telemetry=on_telemetry,
                           failsafe=failsafe, **checked)
    if kind == "http":
        try:
            return HttpLink(robot_id, on_link_state=on_link_state, on_telemetry=on_telemetry,
                            failsafe=failsafe, **checked)
        except ConfigError as exc:
            raise ConfigError(exc.reason, file=source, key=exc.key) from None
    try:
        return MqttLink(robot_id, on_link_state=on_link_state, on_telemetry=on_telemetry,
                        failsafe=failsafe, **checked)
    except ConfigError as exc:
        raise ConfigError(exc.reason, file=source, key=exc.key) from None
