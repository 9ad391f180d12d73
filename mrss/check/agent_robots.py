"""Every robot id the agent names is a robot of project.toml (`[components.rcl.robots.<id>]`).

Which argument holds a robot is read from the program, not guessed from names: the
first argument of every environment action is its robot (the RCL's convention,
`name(Robot, Goal, ...)`), as is `robot_unavailable(R)`'s (MRSS's own percept). An
argument position is `functor/arity#index`; within one clause, the positions one
variable takes are the same kind of thing, so `+!drive(R, ...) <- move(R, ...)` makes
drive/4#0 a robot position, and `robot(R)`, `free(R)`, `busy(R, G)` follow from the
plans that use them. Every atom at a robot position (initial beliefs, plans, rules) must
be a robot id. Not checked when the layer has its own action convention (`action_cb`).
"""

from __future__ import annotations

from pathlib import Path

from mrss.actors.reasoner.give_up import GIVE_UP
from mrss.agentspeak.terms import Slot, Struct
from mrss.check.agent import GOAL_MANAGEMENT, QUERY
from mrss.check.agent_clauses import Clause, SourceLines, literals
from mrss.check.findings import Report, did_you_mean

Position = tuple[str, int, int]  # functor, arity, argument index
ROBOT_PERCEPTS: tuple[Position, ...] = (("robot_unavailable", 1, 0),)
NOT_TYPED = frozenset({QUERY, GOAL_MANAGEMENT, GIVE_UP})  # arguments of many kinds


class _Kinds:
    """Union-find over argument positions: one set per kind of thing."""

    def __init__(self) -> None:
        self.parent: dict[Position, Position] = {}

    def find(self, p: Position) -> Position:
        root = self.parent.setdefault(p, p)
        if root != p:
            root = self.parent[p] = self.find(root)
        return root

    def join(self, a: Position, b: Position) -> None:
        self.parent[self.find(a)] = self.find(b)


def check_robot_ids(clauses: list[Clause], robots: set[str], rcl_where: str,
                    report: Report) -> None:
    """An error at each atom in a robot position that is not in `robots`."""
    kinds = _Kinds()
    seeds: list[Position] = list(ROBOT_PERCEPTS)
    atoms: list[tuple[Position, str, Path, int, int]] = []
    for clause in clauses:
        by_var: dict[str, list[Position]] = {}
        for placed in clause.terms:
            if placed.kind == "action" and type(placed.term) is Struct \
                    and placed.term.args and placed.term.functor not in NOT_TYPED:
                seeds.append((placed.term.functor, len(placed.term.args), 0))
            for lit in literals(placed.term):
                if lit.functor in NOT_TYPED:
                    continue
                for i, arg in enumerate(lit.args):
                    pos = (lit.functor, len(lit.args), i)
                    kinds.find(pos)
                    if type(arg) is Slot and arg.name != "_":
                        by_var.setdefault(arg.name, []).append(pos)
                    elif type(arg) is Struct and not arg.args and not arg.neg:
                        atoms.append((pos, arg.functor, clause.file, placed.line, placed.col))
        for positions in by_var.values():
            for other in positions[1:]:
                kinds.join(positions[0], other)
    robot_kinds = {kinds.find(p) for p in seeds}
    lines = SourceLines()
    reported: set[tuple[str, Path, int]] = set()
    for pos, atom, file, line, col in atoms:
        if atom in robots or kinds.find(pos) not in robot_kinds or (atom, file, line) in reported:
            continue
        reported.add((atom, file, line))
        hint = did_you_mean(atom, robots)
        report.error(str(file), f"{atom!r} is not a robot: argument {pos[2] + 1} of "
                     f"{pos[0]}/{pos[1]} holds a robot id, and {rcl_where} defines the "
                     f"robots {', '.join(sorted(robots)) or 'none'}"
                     + (hint if hint.startswith("; did you mean") else ""),
                     line=line, col=lines.column(file, line, atom, col), check="robots")
