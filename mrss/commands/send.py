"""`mrss send KIND ...`: publish one message on a running system's bus, then exit.

```
mrss send --run-dir DIR percept 'area_goal_received(g1, 3)' [--remove]
mrss send --run-dir DIR control cancel|suspend|resume|succeed|fail TARGET [--kind action|goal|robot]
mrss send --run-dir DIR teleop ROBOT on|off
mrss send --run-dir DIR command NAME [--target T] [--arg KEY=VALUE ...]
mrss send --run-dir DIR raw KIND JSON          # any kind of mrss.messages, fields as JSON
mrss send --run-dir DIR mqtt TOPIC JSON [--project NAME] [--broker URL]
```

`mqtt` is not a bus message: it publishes JSON on TOPIC of the project's MQTT broker as
an outside client would (a citizen's app, a sensor), so the project's events adapter
can be exercised by hand. The broker is `--broker`, else the project's (`[broker] url`
of `--project`'s project.toml, else the embedded broker's `broker.url` in the run dir).

The message is built and validated before anything is sent (a bad literal, field or
JSON exits 2 with the reason and sends nothing); then the sender waits (`--timeout`)
for the bus proxy to join it, publishes, and exits 0 once the message is handed over.
No proxy within the timeout exits 2.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import sys
from pathlib import Path
from typing import Any

from mrss.agentspeak.errors import AslSyntaxError
from mrss.agentspeak.parser import parse_term
from mrss.agentspeak.syntax import MAX_INT_DIGITS
from mrss.agentspeak.terms import Struct, is_ground
from mrss.commands.busargs import add_bus_arguments, connected_publisher, endpoints_from_args
from mrss.config.projects import project_path
from mrss.errors import DecodeError, MrssError
from mrss.links.connect import project_broker_url
from mrss.links.mqtt_publish import publish_json
from mrss.messages import (
    CONTROL_COMMANDS,
    CONTROL_TARGETS,
    KINDS,
    ActionControl,
    Command,
    Message,
    Percept,
    build,
)

EXIT_BAD_INPUT = 2
_NAME = re.compile(r"\A[A-Za-z0-9_-]+(\.[A-Za-z0-9_-]+)*\Z")
_ARG_KEY = re.compile(r"\A[A-Za-z_][A-Za-z0-9_]*\Z")


class BadInput(MrssError):
    """Input that makes no message: a bad literal, field, JSON or topic."""


def configure(parser: argparse.ArgumentParser) -> None:
    add_bus_arguments(parser)
    parser.add_argument("--src", default="mrss-send",
                        help="sender name in the envelope (default mrss-send)")
    parser.add_argument("--topic", default=None,
                        help="publish on this sub-topic of the message's own topic")
    kinds = parser.add_subparsers(dest="kind", metavar="KIND", required=True)

    def kind(name: str, help_text: str) -> argparse.ArgumentParser:
        sub = kinds.add_parser(name, help=help_text, description=help_text)
        add_bus_arguments(sub, again=True)
        return sub

    p = kind("percept", "a percept for the reasoner (an AgentSpeak literal)")
    p.add_argument("literal", help="a ground literal, e.g. 'area_goal_received(g1, 3)'")
    p.add_argument("--remove", action="store_true", help="stop perceiving it")

    c = kind("control", "goal management: an action.control command")
    c.add_argument("command", choices=CONTROL_COMMANDS)
    c.add_argument("target", help="the action uuid, goal or robot")
    c.add_argument("--kind", dest="target_kind", choices=CONTROL_TARGETS, default="action",
                   help="what TARGET names (default action)")

    t = kind("teleop", "switch a robot's teleoperation on or off")
    t.add_argument("robot")
    t.add_argument("state", choices=("on", "off"))

    m = kind("command", "an operator command on ctl.NAME")
    m.add_argument("name", help="command name (the topic is ctl.NAME)")
    m.add_argument("--target", default="", help="what the command is for")
    m.add_argument("--arg", action="append", default=[], metavar="KEY=VALUE",
                   help="an argument; VALUE is read as JSON if it is JSON, else as text")

    q = kind("mqtt", "a JSON message on the project's MQTT broker (not the bus)")
    q.add_argument("mqtt_topic", metavar="TOPIC", help="MQTT topic, e.g. mrss/ui/area")
    q.add_argument("json", metavar="JSON", help="the payload, e.g. '{\"goal\": \"a1\"}'")
    q.add_argument("--project", default=None, metavar="NAME",
                   help="the project whose [broker] url to use (default: the run dir's)")
    q.add_argument("--broker", default=None, metavar="URL", help="this broker instead")

    r = kind("raw", "any message kind, its fields given as a JSON object")
    r.add_argument("message_kind", metavar="KIND", help=f"one of: {', '.join(KINDS)}")
    r.add_argument("json", metavar="JSON", help="the message's fields, e.g. '{\"uuid\": \"a1\"}'")


def run(args: argparse.Namespace) -> int:
    if args.kind == "mqtt":
        return send_mqtt(args)
    try:
        message = build_message(args)
        topic = _topic(message, args.topic)
        endpoints = endpoints_from_args(args)
    except MrssError as exc:
        print(f"mrss send: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    try:
        with connected_publisher(endpoints, args.src, args.timeout) as publisher:
            # an operator's personal token, for a project with users (docs/tui.md)
            publisher.operator = os.environ.get("MRSS_OPERATOR_TOKEN", "")
            msg_id = publisher.publish(message, topic=topic)
        # Leaving the block waited until the message was handed to the proxy.
    except MrssError as exc:
        print(f"mrss send: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    print(f"sent {message.kind} on {topic or message.topic()} (id {msg_id})")
    return 0


def send_mqtt(args: argparse.Namespace) -> int:
    """Publish the JSON payload on the project's broker; exit 2 naming what is wrong."""
    try:
        payload = load_json(args.json)
    except ValueError as exc:
        print(f"mrss send: JSON is not valid: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    topic: str = args.mqtt_topic
    if not topic or any(c in topic for c in "+#\0"):
        print(f"mrss send: {topic!r} is not an MQTT topic to publish on (no wildcards + #)",
              file=sys.stderr)
        return EXIT_BAD_INPUT
    try:
        broker = args.broker or _project_broker(args)
        publish_json(broker, topic, payload, client_id=f"mrss-send-{os.getpid()}",
                     timeout=args.timeout)
    except MrssError as exc:
        print(f"mrss send: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    print(f"published on {topic} via {broker}")
    return 0


def _project_broker(args: argparse.Namespace) -> str:
    run_dir: Path | None = getattr(args, "run_dir", None)
    project = project_path(args.project) if args.project else None
    url = project_broker_url(project, run_dir)
    if not url:
        raise BadInput("no broker: give --broker URL, --project NAME (with a [broker] url), "
                       "or the --run-dir of a system with the embedded broker")
    return url


def build_message(args: argparse.Namespace) -> Message:
    """The message the command line describes; BadInput says why there is none."""
    kind: str = args.kind
    if kind == "percept":
        return Percept(literal=check_literal(args.literal),
                       op="remove" if args.remove else "add")
    if kind == "control":
        return _built(ActionControl, {"command": args.command, "target": args.target,
                                      "target_kind": args.target_kind})
    if kind == "teleop":
        return _built(Command, {"command": "teleop", "target": args.robot,
                                "args": {"on": args.state == "on"}})
    if kind == "command":
        if not _NAME.match(args.name):
            raise BadInput(f"command name {args.name!r} must be letters, digits, '_', '-' "
                           "(dot-separated parts)")
        return _built(Command, {"command": args.name, "target": args.target,
                                "args": parse_args(args.arg)})
    return raw_message(args.message_kind, args.json)


def check_literal(text: str) -> str:
    """`text` stripped, if it is one ground AgentSpeak literal; else BadInput with a caret."""
    literal = text.strip()
    if literal.endswith("."):
        literal = literal[:-1].rstrip()
    if not literal:
        raise BadInput("the percept literal is empty")
    try:
        term = parse_term(literal)
    except AslSyntaxError as exc:
        raise BadInput(_syntax_report(literal, exc)) from None
    if not isinstance(term, Struct):
        raise BadInput(f"bad literal: {literal!r} is not a literal (an atom or a structure)")
    if not is_ground(term):
        raise BadInput(f"bad literal: {literal!r} has variables; a percept must be ground")
    return literal


def _syntax_report(literal: str, exc: AslSyntaxError) -> str:
    """The first syntax problem as `col N: message`, the literal, and a caret under it.

    The parser sees the literal with a terminating `.`; an error on that dot is shown as
    the end of the literal, which is what the user typed.
    """
    problem = exc.problems[0]
    lines = literal.splitlines() or [""]
    source = lines[problem.line - 1] if 0 < problem.line <= len(lines) else problem.source_line
    message = problem.message
    if problem.line == len(lines) and problem.col > len(source) and \
            message.startswith("unexpected '.'"):
        message = "unexpected end of literal" + message[len("unexpected '.'"):]
    where = f"line {problem.line}, col {problem.col}" if len(lines) > 1 else f"col {problem.col}"
    caret = " " * (max(problem.col, 1) - 1) + "^"
    return f"bad literal: {where}: {message}\n    {source}\n    {caret}"


def load_json(text: str) -> Any:
    """`json.loads`, but strict: ValueError for NaN, Infinity, numbers too large for a
    float (`1e400`) and nesting too deep, which Python's decoder would take or crash on."""
    def no_constant(name: str) -> Any:
        raise ValueError(f"{name} is not a JSON number")

    def finite(number: str) -> float:
        value = float(number)
        if not math.isfinite(value):
            raise ValueError(f"number {number[:24]} is too large for a float")
        return value

    def integer(number: str) -> int:
        if len(number.lstrip("-0")) > MAX_INT_DIGITS:
            raise ValueError(f"number {number[:24]}... is too large for a float")
        return int(number)

    try:
        return json.loads(text, parse_constant=no_constant, parse_float=finite,
                          parse_int=integer)
    except RecursionError:
        raise ValueError("nested too deeply") from None


def parse_args(items: list[str]) -> dict[str, Any]:
    """`KEY=VALUE` pairs as a map; a VALUE that is JSON is decoded, any other is text."""
    result: dict[str, Any] = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not _ARG_KEY.match(key):
            raise BadInput(f"--arg {item!r} must be KEY=VALUE with KEY a name")
        try:
            result[key] = load_json(value)
        except ValueError:
            result[key] = value
    return result


def raw_message(kind: str, text: str) -> Message:
    """A message of `kind` from its fields as JSON; BadInput names the problem."""
    cls = KINDS.get(kind)
    if cls is None:
        raise BadInput(f"unknown message kind {kind!r}; kinds: {', '.join(KINDS)}")
    try:
        fields = load_json(text)
    except ValueError as exc:
        raise BadInput(f"JSON is not valid: {exc}") from None
    if not isinstance(fields, dict):
        raise BadInput(f"JSON must be an object of {kind} fields, not {type(fields).__name__}")
    return _built(cls, fields)


def _built(cls: type[Message], fields: dict[str, Any]) -> Message:
    try:
        return build(cls, fields)
    except DecodeError as exc:
        reason = exc.reason if exc.reason.startswith(f"{cls.kind}:") else \
            f"{cls.kind}: {exc.reason}"
        raise BadInput(f"invalid message: {reason}") from None


def _topic(message: Message, topic: str | None) -> str | None:
    """`--topic`, checked to be the message's own topic or a dotted sub-topic of it."""
    if topic is None:
        return None
    own = message.topic()
    if topic != own and not (topic.startswith(own + ".") and _NAME.match(topic)):
        raise BadInput(f"topic {topic!r} must be {own!r} or {own}.SUB")
    return topic
