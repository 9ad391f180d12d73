"""Ground literals read fast: the common ones skip the full AgentSpeak parser.

A percept from the bus is text such as `area_goal_received(g1, 3)`. The full parser (a
whole-program LALR parse) takes ~150 us for it, a third of the reasoner's time per
percept. `read_simple` reads ground literals made of atoms, unsigned numbers, strings
without escapes, lists and nested structures with a small tokenizer, and returns None
for anything else (variables, annotations, negation, operators, escapes, keywords,
errors), which `parse_literal` then hands to the full parser, so results and error
messages stay the parser's own.
"""

from __future__ import annotations

import re

from mrss.agentspeak.arith import ARITY
from mrss.agentspeak.syntax import number_value
from mrss.agentspeak.terms import Struct, Term

_TOKEN = re.compile(
    r"\s*(?:(?P<atom>[a-z][a-zA-Z0-9_]*(?:\.[a-z][a-zA-Z0-9_]*)*)"
    r"|(?P<num>\d+(?:\.\d+)?(?:[eE][+-]?\d+)?)"
    r'|(?P<str>"[^"\\\n]*")'
    r"|(?P<punct>[(),\[\]]))")
_RESERVED = frozenset({"not", "if", "elif", "else", "while", "for", "div", "mod", *ARITY})


class _NotSimple(Exception):
    """The text needs the full parser."""


def read_simple(text: str) -> Struct | None:
    """The ground literal `text` denotes, or None if it needs the full parser."""
    try:
        return _Reader(text.strip().rstrip(".")).literal()
    except _NotSimple:
        return None


class _Reader:
    __slots__ = ("tokens", "pos")

    def __init__(self, text: str) -> None:
        self.tokens: list[tuple[str, str]] = []
        end = 0
        for m in _TOKEN.finditer(text):
            if m.start() != end:
                raise _NotSimple
            end = m.end()
            kind = m.lastgroup
            assert kind is not None
            self.tokens.append((kind, m.group(kind)))
        if end != len(text) or not self.tokens:
            raise _NotSimple
        self.pos = 0

    def literal(self) -> Struct:
        result = self._term()
        if self.pos != len(self.tokens) or not isinstance(result, Struct):
            raise _NotSimple
        return result

    def _next(self) -> tuple[str, str]:
        if self.pos >= len(self.tokens):
            raise _NotSimple
        token = self.tokens[self.pos]
        self.pos += 1
        return token

    def _peek(self) -> str:
        return self.tokens[self.pos][1] if self.pos < len(self.tokens) else ""

    def _term(self) -> Term:
        kind, text = self._next()
        if kind == "num":
            value = number_value(text)
            if value is None:  # too large: the full parser reports it
                raise _NotSimple
            return value
        if kind == "str":
            return text[1:-1]
        if kind == "atom":
            if text in _RESERVED:
                raise _NotSimple
            if self._peek() != "(":
                return Struct(text)
            self.pos += 1
            return Struct(text, self._items(")"))
        if text == "[":
            return self._items("]")
        raise _NotSimple

    def _items(self, close: str) -> tuple[Term, ...]:
        """Comma-separated terms up to `close` (at least one)."""
        items = [self._term()]
        while True:
            _, text = self._next()
            if text == close:
                return tuple(items)
            if text != ",":
                raise _NotSimple
            items.append(self._term())
