"""What the reasoner accepts as a percept from the bus: a well-formed ground literal.

A percept's text is checked before the agent sees it (`checked_literal`):

- at most `MAX_TEXT` bytes of UTF-8 and `MAX_DEPTH` levels of nesting (counted on the
  text, before parsing, so a deeply nested literal never reaches the parser's recursion);
- no exponentiation (`**`, `^`): a percept is data, and `9**9**9` would keep the parser
  computing forever; other arithmetic is folded by the parser and bounded below;
- it parses as one literal, and is ground (no variables, no open list tails);
- every number is finite and every integer within +-2**53;
- no `source(...)` annotation: MRSS sets a percept's source (`source(percept)`) itself,
  so a sender cannot pass a percept off as the agent's own belief (`source(self)`) or an
  agent's message. Such a percept is refused, not stripped: the sender has a bug or is
  lying, and either should show in the counters.

A refused percept raises `Rejected` (mrss.edge.validation) with a short reason; the
reasoner counts it and logs it through `mrss.edge.rejections.RejectionLog`.
"""

from __future__ import annotations

import math

from mrss.agentspeak import AslSyntaxError, Struct, parse_literal
from mrss.agentspeak.terms import PList, Var
from mrss.edge.record_declarations import MAX_INT
from mrss.edge.validation import Rejected

MAX_TEXT = 64 * 1024  # bytes of a percept's text
MAX_DEPTH = 64  # nesting of arguments, lists and annotations
SOURCE = "source"
_OPEN = "([{"
_CLOSE = ")]}"


def _scan(text: str) -> None:
    """Depth and exponentiation, outside quoted strings and atoms."""
    depth = 0
    quote = ""
    escaped = False
    previous = ""
    for char in text:
        if quote:
            if escaped:
                escaped = False
            elif char == "\\":
                escaped = True
            elif char == quote:
                quote = ""
            continue
        if char in "\"'":
            quote = char
        elif char in _OPEN:
            depth += 1
            if depth > MAX_DEPTH:
                raise Rejected("percept nested too deeply", f"more than {MAX_DEPTH} levels")
        elif char in _CLOSE:
            depth -= 1
        elif char == "^" or (char == "*" and previous == "*"):
            raise Rejected("percept has exponentiation", "a percept is data, not arithmetic")
        previous = char


def _walk(term: object) -> None:
    """Ground, finite, bounded: every term inside (iteratively, no recursion)."""
    stack = [term]
    while stack:
        t = stack.pop()
        if isinstance(t, bool):
            continue
        if isinstance(t, int):
            if not -MAX_INT <= t <= MAX_INT:
                raise Rejected("percept number out of range", "|n| > 2**53")
        elif isinstance(t, float):
            if not math.isfinite(t):
                raise Rejected("percept number not finite", repr(t))
        elif isinstance(t, Struct):
            stack.extend(t.args)
            stack.extend(t.annots)
        elif isinstance(t, tuple):
            stack.extend(t)
        elif isinstance(t, (Var, PList)):
            raise Rejected("percept not ground", "it holds a variable")
        elif not isinstance(t, str):
            raise Rejected("percept not ground", f"it holds a {type(t).__name__}")


def checked_literal(text: object) -> Struct:
    """The literal of a percept's text if it is well formed; Rejected otherwise."""
    if not isinstance(text, str):
        raise Rejected("percept not text", f"a {type(text).__name__}")
    size = len(text.encode("utf-8", "replace"))
    if size > MAX_TEXT:
        raise Rejected("percept too large", f"{size} bytes > {MAX_TEXT}")
    _scan(text)
    try:
        literal = parse_literal(text)
    except AslSyntaxError as exc:
        raise Rejected("percept not a literal", str(exc).splitlines()[0][:200]) from None
    except (RecursionError, ValueError, OverflowError, ZeroDivisionError) as exc:
        raise Rejected("percept not a literal", f"{type(exc).__name__}") from None
    for annot in literal.annots:
        if isinstance(annot, Struct) and annot.functor == SOURCE:
            raise Rejected("percept sets its source", "source(...) is set by MRSS")
    _walk(literal)
    return literal
