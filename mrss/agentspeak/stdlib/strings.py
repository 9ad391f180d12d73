"""String internal actions: .term2string .lower_case .upper_case .replace .printf .puts."""

from __future__ import annotations

import re
from typing import Any

from mrss.agentspeak.errors import AslSyntaxError
from mrss.agentspeak.registry import IAContext
from mrss.agentspeak.stdlib import STDLIB
from mrss.agentspeak.stdlib.misc import string_arg, text_of
from mrss.agentspeak.terms import Term, Var, deref, is_number, term_str, value


@STDLIB.action(".term2string", min_args=2, max_args=2)
def term2string(ctx: IAContext, args: list[Any]) -> bool:
    """`.term2string(T, S)`: S is the text of term T; with T free, T is the term
    read from string S."""
    t = value(args[0])
    if type(t) is not Var:
        return ctx.unify(args[1], term_str(t))
    s = deref(args[1])
    if type(s) is not str:
        raise ctx.error("one of the arguments must be bound (a term, or a string to read)")
    from mrss.agentspeak.parser import parse_term

    try:
        return ctx.unify(args[0], parse_term(s))
    except AslSyntaxError as exc:
        raise ctx.error(f"cannot read a term from {s!r}: {exc.problems[0].message}") from None


@STDLIB.action(".lower_case", min_args=2, max_args=2)
def lower_case(ctx: IAContext, args: list[Any]) -> bool:
    """`.lower_case(S, R)`: R is string (or term text) S in lower case."""
    return ctx.unify(args[1], string_arg(ctx, args[0]).lower())


@STDLIB.action(".upper_case", min_args=2, max_args=2)
def upper_case(ctx: IAContext, args: list[Any]) -> bool:
    """`.upper_case(S, R)`: R is S in upper case."""
    return ctx.unify(args[1], string_arg(ctx, args[0]).upper())


@STDLIB.action(".replace", min_args=4, max_args=4)
def replace(ctx: IAContext, args: list[Any]) -> bool:
    """`.replace(S, Old, New, R)`: R is S with every Old replaced by New."""
    s, old, new = (string_arg(ctx, a) for a in args[:3])
    if old == "":
        raise ctx.error("the text to replace is empty")
    return ctx.unify(args[3], s.replace(old, new))


_SPEC = re.compile(r"%(?:%|n|[-#+ 0,(]*\d*(?:\.\d+)?[sdfeExXoc])")


def _format(ctx: IAContext, fmt: str, items: list[Term]) -> str:
    """Java's `String.format` for the usual conversions (%s %d %f %e %x %o %c %n %%)."""
    out: list[str] = []
    pos = 0
    n = 0
    for m in _SPEC.finditer(fmt):
        out.append(fmt[pos:m.start()])
        pos = m.end()
        spec = m.group(0)
        if spec == "%%":
            out.append("%")
            continue
        if spec == "%n":
            out.append("\n")
            continue
        if n >= len(items):
            raise ctx.error(f"the format {fmt!r} needs more arguments than the {len(items)} given")
        arg = value(items[n])
        n += 1
        conv = spec[-1]
        spec = spec.replace(",", "").replace("(", "")
        if conv in "dxXoc":
            if type(arg) is not int and not (type(arg) is float and arg == int(arg)):
                raise ctx.error(f"{spec} needs an integer, not {term_str(arg)}")
            out.append(spec % int(arg))
        elif conv in "feE":
            if not is_number(arg):
                raise ctx.error(f"{spec} needs a number, not {term_str(arg)}")
            out.append(spec % arg)
        else:
            out.append(spec % text_of(arg))
    out.append(fmt[pos:])
    return "".join(out)


@STDLIB.action(".printf", min_args=1)
def printf(ctx: IAContext, args: list[Any]) -> bool:
    """`.printf(Format, Args...)`: print the arguments formatted as by Java's
    `String.format` (`%s`, `%d`, `%5.2f`, `%n`, ...)."""
    fmt = deref(args[0])
    if type(fmt) is not str:
        raise ctx.error(f"the format must be a string, not {term_str(fmt)}")
    text = _format(ctx, fmt, args[1:])
    for line in text.rstrip("\n").split("\n") if text else [""]:
        ctx.runtime.out(line)
    return True


_INTERP = re.compile(r"#\{([A-Z_][A-Za-z0-9_]*)\}")


@STDLIB.action(".puts", min_args=1, max_args=2)
def puts(ctx: IAContext, args: list[Any]) -> bool:
    """`.puts(S)` prints string S with each `#{X}` replaced by the value of the plan's
    variable X; `.puts(S, R)` unifies R with that text instead."""
    s = deref(args[0])
    if type(s) is not str:
        raise ctx.error(f"expected a string, not {term_str(s)}")
    im = ctx.im
    names = im.plan.varnames if im is not None else []

    def var(m: re.Match[str]) -> str:
        name = m.group(1)
        if name in names and im is not None:
            v = im.frame[names.index(name)]
            if v is not None and type(value(v)) is not Var:
                return text_of(v)
        return m.group(0)

    text = _INTERP.sub(var, s)
    if len(args) == 2:
        return ctx.unify(args[1], text)
    ctx.runtime.out(text)
    return True
