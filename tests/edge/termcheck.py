"""An independent reader of ground AgentSpeak literals, for checking what the builder writes.

Written separately from `mrss.agentspeak.literals` (character by character, no regexes) so a
bug in the builder's quoting cannot hide behind the same bug in its own checker. Values
come back as: atoms `("atom", name)`, strings `str`, numbers `int`/`float`, lists `list`,
compound terms `("struct", functor, [args])`.
"""

from __future__ import annotations

from typing import Any

_UNESCAPE = {"n": "\n", "r": "\r", "t": "\t", "b": "\b", "f": "\f", '"': '"', "\\": "\\",
             "'": "'"}


class ReadError(ValueError):
    pass


class Reader:
    def __init__(self, text: str) -> None:
        self.s = text
        self.i = 0

    def _peek(self) -> str:
        return self.s[self.i] if self.i < len(self.s) else ""

    def _expect(self, ch: str) -> None:
        if self._peek() != ch:
            raise ReadError(f"expected {ch!r} at {self.i} in {self.s!r}")
        self.i += 1

    def _name(self) -> str:
        start = self.i
        if not ("a" <= self._peek() <= "z"):
            raise ReadError(f"expected a lowercase name at {self.i} in {self.s!r}")
        while self._peek() and (self._peek().isascii() and (self._peek().isalnum()
                                                             or self._peek() == "_")):
            self.i += 1
        return self.s[start:self.i]

    def _string(self) -> str:
        self._expect('"')
        out = []
        while True:
            ch = self._peek()
            if ch == "":
                raise ReadError("unterminated string")
            self.i += 1
            if ch == '"':
                return "".join(out)
            if ch in "\n\r":
                raise ReadError("raw newline inside a string")
            if ch == "\\":
                esc = self._peek()
                if esc not in _UNESCAPE:
                    raise ReadError(f"unknown escape \\{esc}")
                out.append(_UNESCAPE[esc])
                self.i += 1
            else:
                out.append(ch)

    def _number(self) -> int | float:
        start = self.i
        if self._peek() == "-":
            self.i += 1
        while self._peek().isdigit() or self._peek() in ".eE+-":
            if self._peek() in "+-" and self.s[self.i - 1] not in "eE":
                break
            self.i += 1
        text = self.s[start:self.i]
        is_float = any(c in text for c in ".eE")
        return float(text) if is_float else int(text)

    def _args(self, close: str) -> list[Any]:
        items = [self.term()]
        while self._peek() == ",":
            self.i += 1
            items.append(self.term())
        self._expect(close)
        return items

    def term(self) -> Any:
        ch = self._peek()
        if ch == '"':
            return self._string()
        if ch == "-" or ch.isdigit():
            return self._number()
        if ch == "[":
            self.i += 1
            if self._peek() == "]":
                self.i += 1
                return []
            return self._args("]")
        name = self._name()
        if self._peek() == "(":
            self.i += 1
            return ("struct", name, self._args(")"))
        return ("atom", name)

    def literal(self) -> tuple[str, list[Any], list[Any]]:
        negated = self._peek() == "~"
        if negated:
            self.i += 1
        name = self._name()
        args: list[Any] = []
        annots: list[Any] = []
        if self._peek() == "(":
            self.i += 1
            args = self._args(")")
        if self._peek() == "[":
            self.i += 1
            annots = self._args("]")
        if self.i != len(self.s):
            raise ReadError(f"trailing text {self.s[self.i:]!r}")
        return ("~" if negated else "") + name, args, annots


def read_literal(text: str) -> tuple[str, list[Any], list[Any]]:
    """Functor, arguments and annotations of a ground literal text."""
    return Reader(text).literal()
