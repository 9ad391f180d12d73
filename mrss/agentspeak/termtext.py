"""Jason's text of a term: what `.print`, logs, errors and listings show.

The rules: a number prints as Jason prints it, an integral real without `.0` (8/2
prints 4); a string in double quotes with `\\`, `"` and newlines escaped, or bare at
the top (as `.print` shows it); a strongly negated literal as `~f` (`ns::~f` in a
namespace); the relational and logical operators infix in parentheses, `not (F)`, a
rule as `{ H :- B }`; annotations in brackets after their literal, an open tail as
`|T`; a proper list as `[a,b]`, an open one as `[a,b|T]`; a variable or slot by its
name; an expression infix in parentheses or as a call; a trigger after its operator
(`+!g`); a plan term as its source text.
"""

from __future__ import annotations

from mrss.agentspeak.terms import (
    OP_TEXT,
    AnnotTail,
    Expr,
    PlanTerm,
    PList,
    Slot,
    Struct,
    Term,
    Trigger,
    Var,
    VarAnnot,
    deref,
)

_OPERATORS = {"&", "|", ">", "<", ">=", "<=", "==", "\\==", "="}


def format_number(n: float | int) -> str:
    """Jason prints integral reals without `.0` (8/2 prints 4)."""
    if type(n) is float:
        if n.is_integer() and abs(n) < 1e15:
            return str(int(n))
        return repr(n)
    return str(n)


def quote(s: str) -> str:
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n") + '"'


def term_str(t: Term, top: bool = False) -> str:
    """Jason's text of a term; with `top`, a string prints without quotes (as `.print`)."""
    t = deref(t)
    tt = type(t)
    if tt is str:
        return t if top else quote(t)  # type: ignore
    if tt is int or tt is float:
        return format_number(t)  # type: ignore[arg-type]
    if tt is Struct:
        s: Struct = t  # type: ignore[assignment]
        if s.functor == ":-" and len(s.args) == 2:  # a rule as a term (`.relevant_rules`)
            return f"{{ {term_str(s.args[0])} :- {term_str(s.args[1])} }}"
        if s.functor in _OPERATORS and len(s.args) == 2:
            text = f"({term_str(s.args[0])} {s.functor} {term_str(s.args[1])})"
        elif s.functor == "not" and len(s.args) == 1:
            text = f"not ({term_str(s.args[0])})"
        else:
            text = ("~" + s.functor if "::" not in s.functor else  # ns::~b
                    s.functor.replace("::", "::~", 1)) if s.neg else s.functor
            if s.args:
                text += "(" + ",".join([term_str(a) for a in s.args]) + ")"
        if s.annots:
            text += _annots_str(s.annots)
        return text
    if tt is tuple:
        return "[" + ",".join([term_str(a) for a in t]) + "]"  # type: ignore[union-attr]
    if tt is Var:
        return t.name  # type: ignore[union-attr]
    if tt is PList:
        p: PList = t  # type: ignore[assignment]
        return "[" + ",".join([term_str(a) for a in p.items]) + "|" + term_str(p.tail) + "]"
    if tt is Slot:
        return t.name  # type: ignore[union-attr]
    if tt is Expr:
        e: Expr = t  # type: ignore[assignment]
        if len(e.args) == 2 and not e.op[0].isalpha():
            return f"({term_str(e.args[0])}{e.op}{term_str(e.args[1])})"
        if e.op == "neg":
            return f"(-{term_str(e.args[0])})"
        return e.op + "(" + ",".join([term_str(a) for a in e.args]) + ")"
    if tt is Trigger:
        return OP_TEXT[t.op] + term_str(t.lit)  # type: ignore
    if tt is VarAnnot:
        return term_str(t.var) + _annots_str(t.annots)  # type: ignore[union-attr]
    if tt is AnnotTail:
        return "|" + term_str(t.tail)  # type: ignore[union-attr]
    if tt is PlanTerm:
        from mrss.agentspeak.planterms import plan_term_text
        return plan_term_text(t.src)  # type: ignore[union-attr]
    return repr(t)


def _annots_str(annots: tuple[Term, ...]) -> str:
    last = annots[-1]
    if type(last) is AnnotTail:
        return "[" + ",".join([term_str(a) for a in annots[:-1]]) + term_str(last) + "]"
    return "[" + ",".join([term_str(a) for a in annots]) + "]"


