"""Turn the lark parse tree of one statement into templates (`syntax` classes).

Variables become `Slot`s numbered in order of appearance within the statement; line
numbers are made absolute with the statement's first line.
"""

from __future__ import annotations

from typing import Any

from lark import Token, Transformer, v_args

from mrss.agentspeak.functions import is_function
from mrss.agentspeak.syntax import (
    BeliefSrc,
    BodyItem,
    BodyNode,
    GoalSrc,
    IfItem,
    LoopItem,
    PlanSrc,
    RuleSrc,
    Statement,
    number_value,
)
from mrss.agentspeak.termorder import sort_annots
from mrss.agentspeak.terms import (
    ADD_ACH,
    ADD_BEL,
    ADD_TEST,
    DEL_ACH,
    DEL_BEL,
    DEL_TEST,
    GOAL_STATE,
    AnnotTail,
    Expr,
    PlanTerm,
    PList,
    Slot,
    Struct,
    Term,
    Trigger,
    VarAnnot,
)

DEFAULT_NS = "default::"  # `default::b` is `b`
TRIGGER_OPS = {"+": ADD_BEL, "-": DEL_BEL, "+!": ADD_ACH, "-!": DEL_ACH,
               "+?": ADD_TEST, "-?": DEL_TEST, "^!": GOAL_STATE}



def _unescape(s: str) -> str:
    out: list[str] = []
    i = 0
    while i < len(s):
        c = s[i]
        if c == "\\" and i + 1 < len(s):
            nxt = s[i + 1]
            out.append({"n": "\n", "t": "\t", "r": "\r"}.get(nxt, nxt))
            i += 2
        else:
            out.append(c)
            i += 1
    return "".join(out)


def _short(text: str) -> str:
    return text if len(text) <= 24 else f"{text[:10]}...{text[-6:]} ({len(text)} characters)"


class TreeBuilder(Transformer):  # type: ignore[type-arg]
    """Turns one statement's parse tree into templates; variables become slots."""

    def __init__(self, line0: int, problems: list[tuple[int, int, str]], col0: int = 1) -> None:
        super().__init__()
        self.col0 = col0
        self.scope: dict[str, Slot] = {}
        self.nslots = 0
        self.line0 = line0
        self.problems = problems

    def _slot(self, name: str) -> Slot:
        if name == "_":
            self.nslots += 1
            return Slot(self.nslots - 1, "_")
        s = self.scope.get(name)
        if s is None:
            s = self.scope[name] = Slot(self.nslots, name)
            self.nslots += 1
        return s

    def _line(self, meta: Any) -> int:
        return int(self.line0 + getattr(meta, "line", 1) - 1)

    def _col(self, meta: Any) -> int:
        col = int(getattr(meta, "column", 1))
        return col + self.col0 - 1 if getattr(meta, "line", 1) == 1 else col

    # terms
    def number(self, c: list[Token]) -> Term:
        text = str(c[0])
        value = number_value(text)
        if value is None:
            self.problems.append((c[0].line or 1, c[0].column or 1,
                                  f"number {_short(text)} is too large (the limit is about "
                                  f"1.8e308, the largest finite float)"))
            return 0
        return value

    def string(self, c: list[Token]) -> Term:
        return _unescape(str(c[0])[1:-1])

    def var(self, c: list[Token]) -> Term:
        return self._slot(str(c[0]))

    def args(self, c: list[Any]) -> tuple[str, list[Term]]:
        return ("args", [x for x in c if x is not None])

    def annots(self, c: list[Any]) -> tuple[str, list[Term]]:
        return ("annots", [x for x in c if x is not None])

    def annot_tail(self, c: list[Term]) -> Term:
        return AnnotTail(c[0])

    def goal_var(self, c: list[Token]) -> Term:
        return self._slot(str(c[0]))

    def literal(self, c: list[Any]) -> Term:
        neg = False
        name = ""
        ns = ""
        args: list[Term] = []
        annots: list[Term] = []
        for x in c:
            if isinstance(x, Token):
                if x.type == "NEG":
                    neg = True
                elif x.type == "NS":  # `ns::b`: the namespace is part of the predicate
                    ns = "" if str(x) == DEFAULT_NS else str(x)
                else:
                    name = ns + str(x)
            elif isinstance(x, tuple) and x[0] == "args":
                args = x[1]
            elif isinstance(x, tuple):
                annots = x[1]
        if not neg and not annots and is_function(name, len(args)):
            return Expr(name, tuple(args))
        return Struct(name, tuple(args), sort_annots(tuple(annots)), neg)

    def var_annots(self, c: list[Any]) -> Term:
        return VarAnnot(self._slot(str(c[0])), tuple(c[1][1]))

    def list_tail(self, c: list[Term]) -> tuple[str, Term]:
        return ("tail", c[0])

    def list_term(self, c: list[Any]) -> Term:
        items = [x for x in c if x is not None]
        if items and isinstance(items[-1], tuple) and len(items[-1]) == 2 \
                and items[-1][0] == "tail":
            tail = items.pop()[1]
            return PList(tuple(items), tail)
        return tuple(items)

    @v_args(meta=True)
    def trigger_term(self, meta: Any, c: list[Any]) -> Term:
        label, tok, lit, ctx, body = c
        op = TRIGGER_OPS[str(tok)]
        if label is None and ctx is None and body is None:
            return Trigger(op, lit)
        if type(lit) is not Struct:
            self.problems.append((meta.line, meta.column, "a triggering event needs a literal"))
            lit = Struct("invalid")
        anon = label == ("anon_label",)
        if anon:
            label = None
        return PlanTerm(PlanSrc(label[1] if label else None, op, lit,
                                ctx[1] if ctx else None, body[1] if body else [],
                                self._line(meta), 0, label[2] if label else (),
                                anon_label=anon), False)

    def rule_term(self, c: list[Any]) -> Term:
        return Struct(":-", (c[0], c[2]))

    def and_(self, c: list[Term]) -> Term:
        return Struct("&", (c[0], c[1]))

    def or_(self, c: list[Term]) -> Term:
        return Struct("|", (c[0], c[1]))

    def not_(self, c: list[Term]) -> Term:
        return Struct("not", (c[0],))

    def rel(self, c: list[Any]) -> Term:
        return Struct(str(c[1]), (c[0], c[2]))

    def binop(self, c: list[Any]) -> Term:
        return Expr(str(c[1]), (c[0], c[2]))

    def neg(self, c: list[Term]) -> Term:
        x = c[0]
        if type(x) is int or type(x) is float:
            return -x
        return Expr("neg", (x,))

    # plan bodies
    @v_args(meta=True)
    def simple(self, meta: Any, c: list[Any]) -> BodyNode:
        line = self._line(meta)
        if len(c) == 3:
            return BodyItem("constraint", Struct(str(c[1]), (c[0], c[2])), line)
        t = c[0]
        if type(t) is Expr and t.op.startswith("."):  # `.length(L)` alone: the action
            t = Struct(t.op, t.args)
        if type(t) is Struct:
            kind = "ia" if t.functor.startswith(".") else "action"
            return BodyItem(kind, t, line, self._col(meta))
        self.problems.append((meta.line, meta.column, "expected a body formula (an action, "
                              "internal action, goal, belief update or condition)"))
        return BodyItem("constraint", t, line)

    def _item(self, kind: str, meta: Any, c: list[Any]) -> BodyItem:
        lit = c[-1]
        if type(lit) not in (Struct, Slot, VarAnnot):  # a variable: its value, at run time
            self.problems.append((meta.line, meta.column,
                                  "expected a literal here, not this term"))
        return BodyItem(kind, lit, self._line(meta))

    @v_args(meta=True)
    def achieve(self, meta: Any, c: list[Any]) -> BodyItem:
        return self._item("achieve", meta, c)

    @v_args(meta=True)
    def achieve_new(self, meta: Any, c: list[Any]) -> BodyItem:
        return self._item("achieve_new", meta, c)

    @v_args(meta=True)
    def test_goal(self, meta: Any, c: list[Any]) -> BodyItem:
        return self._item("test", meta, c)

    @v_args(meta=True)
    def add_bel(self, meta: Any, c: list[Any]) -> BodyItem:
        kind = {"+": "add", "+<": "add", "+>": "add_end"}[str(c[0])]
        return self._item(kind, meta, c)

    @v_args(meta=True)
    def del_bel(self, meta: Any, c: list[Any]) -> BodyItem:
        return self._item("del", meta, c)

    @v_args(meta=True)
    def replace_bel(self, meta: Any, c: list[Any]) -> BodyItem:
        return self._item("replace", meta, c)

    def block(self, c: list[Any]) -> list[BodyNode]:
        return c[0] if c and c[0] is not None else []

    def body(self, c: list[Any]) -> list[BodyNode]:
        return [x for x in c if x is not None]

    def elif_part(self, c: list[Any]) -> tuple[Term, list[BodyNode]]:
        return (c[0], c[1])

    def else_part(self, c: list[Any]) -> tuple[str, list[BodyNode]]:
        return ("else", c[0])

    @v_args(meta=True)
    def if_stmt(self, meta: Any, c: list[Any]) -> BodyNode:
        branches: list[tuple[Term, list[BodyNode]]] = [(c[0], c[1])]
        else_body = None
        for x in c[2:]:
            if x is None:
                continue
            if x[0] == "else":
                else_body = x[1]
            else:
                branches.append(x)
        return IfItem(branches, else_body, self._line(meta))

    @v_args(meta=True)
    def while_stmt(self, meta: Any, c: list[Any]) -> BodyNode:
        return LoopItem("while", c[0], c[1], self._line(meta))

    @v_args(meta=True)
    def for_stmt(self, meta: Any, c: list[Any]) -> BodyNode:
        return LoopItem("for", c[0], c[1], self._line(meta))

    # statements
    def label(self, c: list[Any]) -> tuple[str, Any, Any]:
        lit = next((x for x in c if type(x) is Struct), None)
        ann: Any = next((x[1] for x in c if isinstance(x, tuple)), [])
        if lit is not None and lit.annots:  # `@l[atomic]` parses as a literal with annots
            ann = list(lit.annots) + list(ann)
            lit = Struct(lit.functor, lit.args, (), lit.neg)
        return ("label", lit, tuple(ann))

    @v_args(meta=True)
    def var_label(self, meta: Any, c: list[Any]) -> tuple[str]:
        """`@_` in a plan term: no label of its own (the plan library gives it one when
        it is added, as Jason does). A named variable would be a label computed at run
        time, which is not supported: said where it is."""
        if not str(c[0]).startswith("_"):
            self.problems.append((meta.line, meta.column,
                                  f"a plan term's label may be a variable only as `@_` "
                                  f"(no label); `@{c[0]}` is not supported"))
        return ("anon_label",)

    def trigger(self, c: list[Any]) -> tuple[str, int, Term]:
        return ("trigger", TRIGGER_OPS[str(c[0])], c[1])

    def context(self, c: list[Any]) -> tuple[str, Term]:
        return ("context", c[0])

    def plan_body(self, c: list[Any]) -> tuple[str, list[BodyNode]]:
        return ("body", c[1])

    @v_args(meta=True)
    def plan_stmt(self, meta: Any, c: list[Any]) -> Statement:
        parts = {x[0]: x for x in c if isinstance(x, tuple)}
        label = parts.get("label")
        _, op, trig = parts["trigger"]
        if type(trig) is not Struct:
            self.problems.append((meta.line, meta.column, "a triggering event needs a literal"))
            trig = Struct("invalid")
        ctx = parts.get("context")
        body = parts.get("body")
        return PlanSrc(label[1] if label else None, op, trig, ctx[1] if ctx else None,
                       body[1] if body else [], self._line(meta), 0,
                       label[2] if label else ())

    @v_args(meta=True)
    def rule_stmt(self, meta: Any, c: list[Any]) -> Statement:
        return RuleSrc(c[0], c[2], self._line(meta), 0)

    @v_args(meta=True)
    def goal_stmt(self, meta: Any, c: list[Any]) -> Statement:
        return GoalSrc(c[0], self._line(meta))

    @v_args(meta=True)
    def belief_stmt(self, meta: Any, c: list[Any]) -> Statement:
        if type(c[0]) is not Struct:
            self.problems.append((meta.line, meta.column, "expected a belief, rule, goal or plan"))
            return BeliefSrc(Struct("invalid"), self._line(meta))
        return BeliefSrc(c[0], self._line(meta))

    def start(self, c: list[Any]) -> Statement:
        st: Statement = c[0]
        st.nslots = self.nslots
        if isinstance(st, PlanSrc):
            names = ["_"] * self.nslots
            for name, slot in self.scope.items():
                names[slot.index] = name
            st.varnames = names
        return st
