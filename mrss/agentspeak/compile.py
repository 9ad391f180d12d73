"""Compile a parsed `Program` into plans, rules, initial beliefs and initial goals.

Plan bodies become flat instruction lists (`instructions.py`); contexts and
conditions become queries (`formulas.py`). Unknown internal actions and wrong
argument counts are reported with file and line, all of them at once.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mrss.agentspeak.beliefs import Rule, has_source
from mrss.agentspeak.beliefvar import BeliefVar
from mrss.agentspeak.depth import PARSE_DEPTH
from mrss.agentspeak.errors import AslRuntimeError, AslSyntaxError, SyntaxProblem
from mrss.agentspeak.formulas import Query, compile_query
from mrss.agentspeak.functions import FunctionEnv, bind_functions
from mrss.agentspeak.instructions import (
    Achieve,
    AchieveNew,
    AchieveNewVar,
    AchieveVar,
    Action,
    AddBelief,
    CallIA,
    Constraint,
    DelBelief,
    ForNext,
    Instr,
    Jump,
    JumpUnless,
    ReplaceBelief,
    TestGoal,
    WhileTest,
)
from mrss.agentspeak.plans import Plan
from mrss.agentspeak.registry import Registry
from mrss.agentspeak.rulechange import AddRule, DelRule, is_rule_term
from mrss.agentspeak.syntax import (
    BeliefSrc,
    BodyItem,
    BodyNode,
    GoalSrc,
    IfItem,
    LoopItem,
    PlanSrc,
    Program,
    RuleSrc,
    Statement,
)
from mrss.agentspeak.termorder import add_annot
from mrss.agentspeak.terms import (
    ADD_ACH,
    OP_TEXT,
    SOURCE_SELF,
    AnnotTail,
    Slot,
    Struct,
    Term,
    VarAnnot,
    term_str,
)
from mrss.agentspeak.unify import resolve
from mrss.agentspeak.unsupported import unknown_action_message


@dataclass
class Compiled:
    """Everything an agent is built from."""

    file: str
    beliefs: list[Struct] = field(default_factory=list)
    rules: list[Rule] = field(default_factory=list)
    goals: list[Struct] = field(default_factory=list)
    plans: list[Plan] = field(default_factory=list)
    functions: FunctionEnv = field(default_factory=FunctionEnv)  # the agent sets .rt
    clauses: list[Struct | Rule] = field(default_factory=list)  # beliefs and rules in order


def with_self_source(lit: Struct) -> Struct:
    """`lit` annotated `source(self)` unless it names a source already."""
    if has_source(lit.annots):
        return lit
    return Struct(lit.functor, lit.args, add_annot(lit.annots, SOURCE_SELF), lit.neg)


class _Compiler:
    def __init__(self, program: Program, registry: Registry, lines: list[str]) -> None:
        self.program = program
        self.registry = registry
        self.lines = lines
        self.problems: list[SyntaxProblem] = []
        self.env = FunctionEnv()
        self.included: str | None = None  # the file of the statement compiled, if another

    def problem(self, line: int, message: str, col: int = 0) -> None:
        file, lines = self.program.file, self.lines
        if self.included is not None:  # a statement of an included file
            file = self.included
            try:
                lines = Path(file).read_text(encoding="utf-8").splitlines()
            except (OSError, UnicodeDecodeError):
                lines = []
        src = lines[line - 1] if 0 < line <= len(lines) else ""
        col = col or len(src) - len(src.lstrip()) + 1
        self.problems.append(SyntaxProblem(file, line, col, message, src))

    def bind(self, t: Term, line: int) -> None:
        """Attach the implementations of the functions (`.count(Q)`, ...) inside `t`."""
        found: list[str] = []
        bind_functions(t, self.env, lambda q: self.query(q, line), found)
        for message in found:
            self.problem(line, message)

    def query(self, t: Term, line: int) -> Query:
        self.bind(t, line)
        try:
            self._check_ias(t, line)
            return compile_query(t, self.registry)
        except AslRuntimeError as exc:
            self.problem(line, exc.message)
            return compile_query(Struct("false"), self.registry)

    def _check_ias(self, t: Term, line: int) -> None:
        if type(t) is Struct:
            if t.functor.startswith("."):
                self._ia(t, line)
            for a in t.args:
                self._check_ias(a, line)

    def _ia(self, lit: Struct, line: int, col: int = 0) -> Any:
        ia = self.registry.get(lit.functor)
        if ia is None:
            self.problem(line, unknown_action_message(lit.functor), col)
            return None
        n = len(lit.args)
        if n < ia.min_args or (ia.max_args is not None and n > ia.max_args):
            self.problem(line, f"{lit.functor} takes {ia.min_args}"
                         + ("" if ia.max_args == ia.min_args else
                            f" to {ia.max_args if ia.max_args is not None else 'any'}")
                         + f" arguments, not {n}", col)
            return None
        return ia

    def body(self, nodes: list[BodyNode], code: list[Instr]) -> None:
        for node in nodes:
            if isinstance(node, BodyItem):
                self.item(node, code)
            elif isinstance(node, IfItem):
                ends: list[Jump] = []
                for i, (cond, branch) in enumerate(node.branches):
                    test = JumpUnless(self.query(cond, node.line), cond, node.line,
                                      "if" if i == 0 else "elif")
                    code.append(test)
                    self.body(branch, code)
                    end = Jump(-1, node.line)
                    code.append(end)
                    ends.append(end)
                    test.target = len(code)
                if node.else_body is not None:
                    self.body(node.else_body, code)
                for end in ends:
                    end.target = len(code)
            else:
                self.loop(node, code)

    def loop(self, node: LoopItem, code: list[Instr]) -> None:
        head: WhileTest | ForNext
        q = self.query(node.cond, node.line)
        head = WhileTest(q, node.cond, node.line) if node.kind == "while" \
            else ForNext(q, node.cond, node.line)
        start = len(code)
        code.append(head)
        self.body(node.body, code)
        code.append(Jump(start, node.line))
        head.target = len(code)

    def item(self, node: BodyItem, code: list[Instr]) -> None:
        kind, t, line = node.kind, node.term, node.line
        self.bind(t, line)
        if kind == "constraint":
            code.append(Constraint(self.query(t, line), t, line))
            return
        if kind == "test":
            code.append(TestGoal(t, self.query(t, line), line))
            return
        if kind in ("achieve", "achieve_new") and type(t) in (Slot, VarAnnot):
            code.append(AchieveVar(t, line) if kind == "achieve" else AchieveNewVar(t, line))
            return
        if kind in ("add", "add_end", "del", "replace") and type(t) in (Slot, VarAnnot):
            code.append(BeliefVar(kind, t, line))
            return
        if type(t) is not Struct:
            self.problem(line, f"expected a literal, not {term_str(t)}")
            return
        if kind == "achieve":
            code.append(Achieve(with_self_source(t), line))
        elif kind == "achieve_new":
            code.append(AchieveNew(with_self_source(t), line))
        elif kind in ("add", "add_end", "del") and is_rule_term(t):
            self._check_ias(t.args[1], line)
            code.append(AddRule(t, line) if kind != "del" else DelRule(t, line))
        elif kind in ("add", "add_end"):
            code.append(AddBelief(with_self_source(t), kind == "add", line))
        elif kind == "del":
            code.append(DelBelief(with_self_source(t), line))
        elif kind == "replace":
            code.append(ReplaceBelief(with_self_source(t), line))
        elif kind == "ia":
            ia = self._ia(t, line, node.col)
            if ia is None:
                return
            queries = {i: self.query(t.args[i], line) for i in ia.formula_args
                       if i < len(t.args) and type(t.args[i]) is Struct}
            code.append(CallIA(ia, t, queries, line))
        elif kind == "action":
            if t.functor == "true" and not t.args:
                return
            for a in t.args:
                self._check_ias(a, line)
            code.append(Action(t, line))

    def plan(self, src: PlanSrc) -> Plan:
        code: list[Instr] = []
        self.body(src.body, code)
        for i, ins in enumerate(code):  # tail position: only free jumps to the end follow
            if isinstance(ins, Achieve):
                j = i + 1
                while j < len(code) and type(code[j]) is Jump:
                    j = code[j].target  # type: ignore[attr-defined]
                    if j <= i:
                        break
                ins.tail = j >= len(code)
                g = ins.lit
                ins.self_call = (src.op == ADD_ACH and type(g) is Struct
                                 and g.functor == src.trigger.functor
                                 and len(g.args) == len(src.trigger.args)
                                 and g.neg == src.trigger.neg)
        ctx = src.context
        context = None
        if ctx is not None and not (type(ctx) is Struct and ctx.functor == "true"
                                    and not ctx.args):
            context = self.query(ctx, src.line)
        plan = Plan(src.label, src.op, src.trigger, context, code, src.nslots, src.line,
                    src.file or self.program.file, src.annots, src.varnames)
        plan.src = src
        return plan

    def run(self) -> Compiled:
        out = Compiled(self.program.file, functions=self.env)
        for st in self.program.statements:
            self.included = st.file
            try:
                self.statement(st, out)
            except RecursionError:
                self.problem(st.line, f"a term is nested too deeply (more than about "
                                      f"{PARSE_DEPTH} levels)")
        return out

    def statement(self, st: Statement, out: Compiled) -> None:
        if isinstance(st, PlanSrc):
            self._check_ias(st.trigger, st.line)
            self.bind(st.trigger, st.line)
            out.plans.append(self.plan(st))
        elif isinstance(st, RuleSrc):
            self.bind(st.head, st.line)
            text = f"{term_str(st.head)} :- {term_str(st.body)}"
            out.rules.append(Rule(st.head, self.query(st.body, st.line), st.nslots,
                                  st.line, text))
            out.rules[-1].src_body = st.body
            out.clauses.append(out.rules[-1])
        else:
            lit = self.initial(st)
            if lit is not None:
                (out.beliefs if isinstance(st, BeliefSrc) else out.goals).append(
                    with_self_source(lit))
                if isinstance(st, BeliefSrc):
                    out.clauses.append(out.beliefs[-1])

    def initial(self, st: BeliefSrc | GoalSrc) -> Struct | None:
        """The runtime literal of an initial belief or goal (its arithmetic evaluated)."""
        if st.lit.ground:
            return st.lit
        if st.lit.annots and type(st.lit.annots[-1]) is AnnotTail:
            self.problem(st.line, "an initial belief or goal cannot have an annotation tail "
                                  f"({term_str(st.lit)})")
            return None
        self.bind(st.lit, st.line)
        try:
            lit: Any = resolve(st.lit, [None] * st.nslots)
        except AslRuntimeError as exc:
            self.problem(st.line, exc.message)
            return None
        return lit  # type: ignore[no-any-return]


def compile_program(program: Program, registry: Registry, text: str = "",
                    problems: list[SyntaxProblem] | None = None) -> Compiled:
    """Compile a parsed program; raise `AslSyntaxError` listing every problem (those
    already found by the parser, passed in `problems`, included)."""
    c = _Compiler(program, registry, text.splitlines())
    out = c.run()
    found = list(dict.fromkeys(list(problems or []) + c.problems))  # each once
    if found:
        raise AslSyntaxError(sorted(found, key=lambda p: (p.line, p.col)))
    return out


def plan_text(plan: Plan) -> str:
    """A one-line summary of a plan for snapshots: label and trigger."""
    label = f"@{term_str(plan.label)} " if plan.label is not None else ""
    return f"{label}{OP_TEXT[plan.op]}{term_str(plan.trigger)}"


def compile_plan(src: PlanSrc, registry: Registry, file: str) -> Plan:
    """Compile one plan added at run time (`.add_plan`); `AslRuntimeError` if invalid."""
    c = _Compiler(Program(file), registry, [])
    c._check_ias(src.trigger, src.line)
    c.bind(src.trigger, src.line)
    plan = c.plan(src)
    if c.problems:
        raise AslRuntimeError(c.problems[0].message)
    return plan
