"""The bus messages an operator sends from the TUI, built and checked before anything goes out.

- a percept typed on the input line: `fire(area1)` adds it, `-fire(area1)` removes it;
  it must parse as one ground AgentSpeak literal, or `OperatorError` says why;
- `action.control` for the selected action (cancel / suspend / resume);
- `ctl.teleop` for a robot, `ctl.fault` for a component (executed by the root supervisor,
  `mrss.runtime.remote`), `ctl.mind` and `ctl.tree` snapshot requests;
- `ctl.snapshot` (the RCL re-announces every robot and open action), with an
  `action.query` for the actions the dashboard believes open, and `ctl.stop` (the
  root supervisor stops the whole system in order);
- `wm.list` on `dl.request.wm`: the world model's objects, for the map.
"""

from __future__ import annotations

from mrss.agentspeak import AslSyntaxError, parse_literal
from mrss.agentspeak.terms import Struct
from mrss.messages import (
    ActionControl,
    ActionQuery,
    Command,
    ControlCommand,
    ControlTarget,
    DataRequest,
    Percept,
)

FAULTS = ("kill", "hang", "crash", "term")
ACTION_COMMANDS = ("cancel", "suspend", "resume")


class OperatorError(ValueError):
    """Operator input that cannot become a bus message; the text says what to fix."""


def parse_percept(text: str) -> Percept:
    """The Percept for an input line; OperatorError (nothing to send) if it is not one."""
    literal = text.strip()
    op = "add"
    if literal.startswith("-"):
        op, literal = "remove", literal[1:].strip()
    elif literal.startswith("+"):
        literal = literal[1:].strip()
    literal = literal.rstrip(".").rstrip()
    if not literal:
        raise OperatorError("type a literal, e.g. fire(area1); -fire(area1) removes it")
    try:
        parsed = parse_literal(literal)
    except AslSyntaxError as exc:
        raise OperatorError(f"not a literal: {_first_problem(exc, len(literal))}") from None
    except (AssertionError, ValueError, RecursionError):
        raise OperatorError(f"not a literal: {literal!r}") from None
    if not isinstance(parsed, Struct):
        raise OperatorError(f"not a literal: {literal!r}")
    if not parsed.ground:
        raise OperatorError(f"a percept must be ground (no variables): {literal}")
    return Percept(literal=literal, op=op)


def _first_problem(exc: AslSyntaxError, length: int) -> str:
    """The parser's first complaint, without the `<term>:1:` location of a one-liner.

    The parser reads the line with a final `.` added; a complaint about that `.` means
    the literal ended too early (an unclosed bracket, say).
    """
    line = str(exc).splitlines()[0] if str(exc) else "syntax error"
    prefix = "<term>:1:"
    if not line.startswith(prefix):
        return line
    col, _, rest = line[len(prefix):].partition(": ")
    if not col.isdigit():
        return line
    if int(col) == length + 1 and rest.startswith("unexpected '.'"):
        return "it ends too early" + rest[len("unexpected '.'"):]
    return f"column {col}: {rest}"


def action_control(command: str, uuid: str) -> ActionControl:
    """cancel / suspend / resume one action."""
    if command not in ACTION_COMMANDS:
        raise OperatorError(f"unknown action command {command!r}")
    if not uuid:
        raise OperatorError("no action selected")
    return ActionControl(command=ControlCommand(command), target=uuid,
                         target_kind=ControlTarget.ACTION)


def teleop(robot: str, on: bool) -> Command:
    """Hand `robot` to (or take it back from) the operator: on `ctl.teleop`."""
    if not robot:
        raise OperatorError("no robot selected")
    return Command(command="teleop", target=robot, args={"on": on})


def fault(component: str, kind: str) -> Command:
    """Ask the root supervisor to inject a process fault into `component`: on `ctl.fault`."""
    if kind not in FAULTS:
        raise OperatorError(f"unknown fault {kind!r}; known: {', '.join(FAULTS)}")
    if not component:
        raise OperatorError("no component selected")
    return Command(command="fault", target=component, args={"fault": kind})


def mind_request(agent: str = "") -> Command:
    """Ask the reasoner(s) for a `mind.<name>` snapshot: on `ctl.mind`."""
    return Command(command="mind", target=agent)


def questions_request() -> Command:
    """Ask the reasoner(s) for their pending questions again: on `ctl.questions`."""
    return Command(command="questions")


def tree_request() -> Command:
    """Ask the root supervisor for a `sup.tree` snapshot: on `ctl.tree`."""
    return Command(command="tree")


def snapshot_request() -> Command:
    """Ask the RCL for every robot's state and every open action's status: `ctl.snapshot`."""
    return Command(command="snapshot")


QUERY_LIMIT = 500  # uuids per ActionQuery


def status_query(uuids: list[str]) -> ActionQuery:
    """Ask the RCL for the journaled status of actions the dashboard believes open (the
    reconciliation query the reasoner uses): one that ended unseen shows its end."""
    return ActionQuery(uuids=uuids[:QUERY_LIMIT])


def stop_request(root: str) -> Command:
    """Ask the root supervisor `root` to stop the whole system in order: on `ctl.stop`."""
    if not root:
        raise OperatorError("the system's name is not known yet")
    return Command(command="stop", target=root)


WORLD_REQUEST_PREFIX = "tui-wm-"


def world_request(serial: int) -> DataRequest:
    """Ask the world model for every object (`wm.list`), on `dl.request.wm`."""
    return DataRequest(request_id=f"{WORLD_REQUEST_PREFIX}{serial}", function="wm.list",
                       args=[None])
