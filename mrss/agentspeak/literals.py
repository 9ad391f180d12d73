"""Build AgentSpeak literal strings from Python values, safely.

Outside data never becomes AgentSpeak syntax: a Python `str` is always a quoted string
with `"` and `\\` escaped, so a field holding `"), evil(` stays one string argument.
Atoms are explicit (`Atom("h1")`, validated as lowercase identifiers) or chosen by
`symbol()`, which makes an atom only of a valid lowercase identifier and a string of
anything else. Numbers must be finite; `bool` becomes `true`/`false`; lists and tuples
become AgentSpeak lists; `Struct` nests compound terms.

    literal("hotspot_detected", Atom("h1"), 43.6, 1.44)  -> 'hotspot_detected(h1,43.6,1.44)'
    literal("note", 'say "hi"')                          -> 'note("say \\"hi\\"")'

`check_literal(text)` validates a hand-written ground literal before it is published.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass
from decimal import Decimal
from typing import TypeAlias

from mrss.errors import MrssError

_ATOM_RE = re.compile(r"[a-z][a-zA-Z0-9_]*\Z")
#: Words the AgentSpeak grammar reserves; as data they are quoted, never bare atoms.
#: `neg` is an arithmetic function: bare, it is a call (mrss.agentspeak.arith.ARITY).
RESERVED = frozenset({
    "not", "div", "mod", "true", "false", "if", "elif", "else", "for", "while",
    "begin", "end", "include", "namespace", "register_function", "neg",
})
_ESCAPES = {'"': '\\"', "\\": "\\\\", "\n": "\\n", "\r": "\\r", "\t": "\\t",
            "\b": "\\b", "\f": "\\f"}
_ESCAPE_RE = re.compile(r'["\\\n\r\t\b\f]')


class PredicateError(MrssError, ValueError):
    """A value cannot be written as an AgentSpeak term, or a literal text is malformed."""


class Atom(str):
    """An AgentSpeak atom: a lowercase identifier, validated on creation."""

    __slots__ = ()

    def __new__(cls, name: str) -> Atom:
        if not is_atom_name(name):
            raise PredicateError(f"{name!r} is not a valid atom (lowercase identifier)")
        return super().__new__(cls, name)


@dataclass(frozen=True)
class Struct:
    """A compound term `functor(args...)` nested inside a literal."""

    functor: str
    args: tuple[Term, ...] = ()

    def __init__(self, functor: str, *args: Term) -> None:
        object.__setattr__(self, "functor", functor)
        object.__setattr__(self, "args", tuple(args))


Term: TypeAlias = "Atom | Struct | str | int | float | bool | Sequence[Term]"


def is_atom_name(text: str) -> bool:
    """True when `text` may be written as a bare atom (and is not a reserved word)."""
    return isinstance(text, str) and bool(_ATOM_RE.match(text)) and text not in RESERVED


def symbol(text: str) -> Atom | str:
    """An atom when `text` is a valid lowercase identifier, otherwise the quoted string."""
    return Atom(text) if is_atom_name(text) else text


def quote(text: str) -> str:
    """`text` as an AgentSpeak string literal, escaped."""
    try:
        text.encode("utf-8")
    except UnicodeEncodeError as exc:
        raise PredicateError(f"string is not valid Unicode text: {exc.reason}") from None
    return '"' + _ESCAPE_RE.sub(lambda m: _ESCAPES[m.group()], text) + '"'


def number(value: int | float) -> str:
    """A finite number in plain positional notation (no exponent, so any grammar reads it)."""
    if isinstance(value, bool):
        raise PredicateError("a bool is not a number")
    if isinstance(value, int):
        return str(value)
    if not math.isfinite(value):
        raise PredicateError(f"number {value!r} is not finite")
    text = format(Decimal(repr(value)), "f")
    return text if "." in text else text + ".0"


def term(value: object) -> str:
    """The AgentSpeak text of one term; PredicateError for anything not representable."""
    if isinstance(value, Atom):
        return str(value)
    if isinstance(value, str):
        return quote(value)
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return number(value)
    if isinstance(value, Struct):
        return _compound(value.functor, value.args)
    if isinstance(value, (list, tuple)):
        return "[" + ",".join(term(v) for v in value) + "]"
    raise PredicateError(f"cannot write a {type(value).__name__} as an AgentSpeak term")


def literal(functor: str, *args: Term, annotations: Sequence[Term] = ()) -> str:
    """A ground literal `functor(args)[annotations]`; `~functor` for strong negation."""
    negated = functor.startswith("~")
    text = _compound(functor[1:] if negated else functor, args)
    if annotations:
        text += "[" + ",".join(term(a) for a in annotations) + "]"
    return "~" + text if negated else text


def _compound(functor: str, args: Sequence[object]) -> str:
    if not is_atom_name(functor):
        raise PredicateError(f"functor {functor!r} is not a valid atom (lowercase identifier)")
    if not args:
        return functor
    return functor + "(" + ",".join(term(a) for a in args) + ")"


# --- validation of hand-written literal text ---------------------------------------

_TOKEN_RE = re.compile(
    r"""\s*(?:
      (?P<string>"(?:[^"\\\n\r]|\\.)*")
    | (?P<number>-?(?:\d+\.\d+|\d+|\.\d+)(?:[eE][+-]?\d+)?)
    | (?P<atom>[a-z][a-zA-Z0-9_]*)
    | (?P<punct>[()\[\],~])
    )""",
    re.VERBOSE,
)


def _tokens(text: str) -> list[tuple[str, str, int]]:
    out: list[tuple[str, str, int]] = []
    pos = 0
    while pos < len(text):
        if text[pos:].strip() == "":
            break
        match = _TOKEN_RE.match(text, pos)
        if match is None or match.lastgroup is None:
            raise PredicateError(f"unexpected character {text[pos:].lstrip()[:1]!r} at "
                                 f"{pos} in literal {text!r}")
        out.append((match.lastgroup, match.group(match.lastgroup), match.start(match.lastgroup)))
        pos = match.end()
    return out


class _Checker:
    """Recursive descent over the token list of one ground literal."""

    def __init__(self, text: str) -> None:
        self.text = text
        self.toks = _tokens(text)
        self.i = 0

    def fail(self, what: str) -> PredicateError:
        where = self.toks[self.i][2] if self.i < len(self.toks) else len(self.text)
        return PredicateError(f"{what} at {where} in literal {self.text!r}")

    def peek(self) -> str:
        return self.toks[self.i][1] if self.i < len(self.toks) else ""

    def take(self, kind: str | None = None, value: str | None = None) -> str:
        if self.i >= len(self.toks):
            raise self.fail("unexpected end")
        k, v, _ = self.toks[self.i]
        if (kind and k != kind) or (value and v != value):
            raise self.fail(f"expected {value or kind}, found {v!r}")
        self.i += 1
        return v

    def literal(self) -> None:
        if self.peek() == "~":
            self.take(value="~")
        self.compound()
        if self.peek() == "[":
            self.sequence("[", "]")
        if self.i != len(self.toks):
            raise self.fail("trailing text")

    def compound(self) -> None:
        name = self.take("atom")
        if name in RESERVED:
            raise self.fail(f"reserved word {name!r} used as a functor")
        if self.peek() == "(":
            self.sequence("(", ")")

    def sequence(self, open_: str, close: str) -> None:
        self.take(value=open_)
        if close == "]" and self.peek() == "]":
            self.take(value="]")
            return
        self.term()
        while self.peek() == ",":
            self.take(value=",")
            self.term()
        self.take(value=close)

    def term(self) -> None:
        kind = self.toks[self.i][0] if self.i < len(self.toks) else ""
        bare_constant = kind == "atom" and self.peek() in ("true", "false")
        if kind in ("string", "number") or bare_constant:
            self.i += 1
        elif kind == "atom":
            self.compound()
        elif self.peek() == "[":
            self.sequence("[", "]")
        else:
            raise self.fail("expected a term")


def check_literal(text: str) -> str:
    """Return `text` stripped if it is a well-formed ground literal, else PredicateError."""
    if not isinstance(text, str) or not text.strip():
        raise PredicateError("literal is empty")
    _Checker(text).literal()
    return text.strip()
