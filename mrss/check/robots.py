"""Robot tables of the RCL: ids the agent can name, link kinds and their options.

A robot's keys are its link kind's options (`mrss.links.factory.LINK_OPTIONS`), typed,
with URLs parsed (a MAVLink `url` as `udpin:HOST:PORT`, an MQTT `broker_url` as
`mqtt://host:port`, an HTTP `url` as `http://host:port`), or keys the layer reads
itself (`robot_settings`: names, or
`mrss.api.Option`s whose type and check are validated here, with or without a link).
Required link options are not enforced: the project's connect_robot may fill them in.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from mrss.actors.rcl.allocation.profile import ALLOCATION_KEYS, ROBOT_ALLOCATION_OPTIONS
from mrss.agentspeak.literals import is_atom_name
from mrss.check.exposure import warn_secret
from mrss.check.findings import Report, did_you_mean
from mrss.check.options import mavlink_url_problem, url_problem, value_problem
from mrss.check.toml_lines import key_line
from mrss.config.project import ProjectConfig
from mrss.links.connect import MQTT_FILES
from mrss.links.factory import LINK_OPTIONS, option_value_problems
from mrss.links.http_protocol import http_url_problem
from mrss.links.mavlink_signing import key_problem
from mrss.options import Option

# Keys of a robot's table that the RCL reads itself, whatever its link: the link kind, the
# node it is reached through (mrss.config.nodes; validated there), and what it declares
# for tasks addressed to a role (mrss.actors.rcl.allocation.profile; validated here).
ROBOT_KEYS = ("link", "node", *ALLOCATION_KEYS)
URL_OPTIONS = {("mavlink", "url"): mavlink_url_problem, ("mqtt", "broker_url"): url_problem,
               ("http", "url"): http_url_problem}


def check_robots(config: ProjectConfig, report: Report, comp_id: str, robots: Any,
                 own: set[str], settings: Mapping[str, Option] | None = None) -> list[str]:
    """Findings for `[components.<id>.robots]`; the robot descriptions for the summary."""
    key = f"components.{comp_id}.robots"
    if not isinstance(robots, Mapping) or not robots:
        report.error(str(config.file), "the RCL needs a table of robots, e.g. "
                     f"[components.{comp_id}.robots.robot1]", line=key_line(config, key),
                     check="robots", key=key)
        return []
    described = []
    for robot, options in robots.items():
        rkey = f"{key}.{robot}"
        if not is_atom_name(str(robot)):
            report.error(str(config.file), "a robot id must be a lowercase identifier (the "
                         "agent names it as an atom)", line=key_line(config, rkey),
                         check="robots", key=rkey)
        if not isinstance(options, Mapping):
            report.error(str(config.file), "must be a table", line=key_line(config, rkey),
                         check="robots", key=rkey)
            continue
        for option in ROBOT_ALLOCATION_OPTIONS:
            if option.name in options and option.name not in (settings or {}):
                problem = value_problem(option, options[option.name], config.directory)
                caps = options[option.name]
                if not problem and option.name == "capabilities" and not all(
                        isinstance(c, str) and is_atom_name(c) for c in caps):
                    problem = ("capabilities are lowercase names the agent writes as atoms "
                               f"(any([uav, camera])), not {caps!r}")
                if problem:
                    report.error(str(config.file), f"{problem} ({option.doc})",
                                 line=key_line(config, f"{rkey}.{option.name}"),
                                 check="robots", key=f"{rkey}.{option.name}")
        for name, option in (settings or {}).items():
            if name in options:
                problem = value_problem(option, options[name], config.directory)
                if problem:
                    report.error(str(config.file), f"{problem} ({option.doc})" if option.doc
                                 else problem, line=key_line(config, f"{rkey}.{name}"),
                                 check="robots", key=f"{rkey}.{name}")
        kind = options.get("link")
        if kind is None:
            described.append(str(robot))
            continue
        problems = link_problems(str(kind), options, own)
        key_file = options.get("signing_key")
        if kind == "mavlink" and isinstance(key_file, str) and "signing_key" not in own:
            problem = key_problem(config.directory / key_file, key_file)
            if problem:
                problems.append(("signing_key", problem))
            if not problem:
                warn_secret(config, report, f"{rkey}.signing_key", key_file,
                            "signing key file")
        if kind == "mqtt":
            problems += mqtt_file_problems(config, report, rkey, options, own)
        for name, problem in problems:
            report.error(str(config.file), problem, line=key_line(config, f"{rkey}.{name}"),
                         check="robots", key=f"{rkey}.{name}")
        described.append(f"{robot} ({kind})")
    return described


def mqtt_file_problems(config: ProjectConfig, report: Report, rkey: str,
                       options: Mapping[str, Any], own: set[str]) -> list[tuple[str, str]]:
    """(key, problem) for an MQTT robot's login and TLS files (project-relative files
    that must exist); a warning for a password or key file others can read."""
    problems = []
    for name in MQTT_FILES:
        value = options.get(name)
        if name in own or not isinstance(value, str):
            continue
        if not (config.directory / value).is_file():
            problems.append((name, f"no file {value!r} in the project folder"))
        elif name in ("password_file", "keyfile"):
            warn_secret(config, report, f"{rkey}.{name}", value,
                        "password file" if name == "password_file" else "TLS key file")
    return problems


def link_problems(kind: str, options: Mapping[str, Any],
                  own: set[str]) -> list[tuple[str, str]]:
    """(key, problem) for a robot's link options: kind known, no unknown key, right types,
    URLs that parse."""
    if kind not in LINK_OPTIONS:
        return [("link", f"unknown link kind {kind!r}" + did_you_mean(kind, LINK_OPTIONS))]
    spec = LINK_OPTIONS[kind]
    problems = []
    for name, value in options.items():
        if name in ROBOT_KEYS or name in own:
            continue
        if name not in spec:
            problems.append((name, f"not a {kind} link option"
                             + did_you_mean(name, [*spec, *own], what="known")
                             + "; list the layer's own keys in its robot_settings"))
            continue
        expected, _ = spec[name]
        ok = isinstance(value, expected) and not isinstance(value, bool)
        if expected is float and isinstance(value, int) and not isinstance(value, bool):
            ok = True
        if not ok:
            problems.append((name, f"must be of type {expected.__name__}, not {value!r}"))
            continue
        parse = URL_OPTIONS.get((kind, name))
        problem = parse(value) if parse else None
        if problem:
            problems.append((name, problem))
    typed = {key for key, _ in problems}
    problems += [p for p in option_value_problems(options) if p[0] not in typed]
    return problems
