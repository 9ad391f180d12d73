"""The log pane's lines as entries (text, level, component) and its `/` filter (no Textual).

A filter is words, all of which must match a line (case-insensitive):

- `level:warning` (or `l:w`, `level:err`): the line's level is that one or worse;
- `comp:rcl` (or `c:rcl`, `@rcl`): the line's component contains `rcl`;
- any other word: the line's text (without its time stamp) contains it.

An empty filter shows everything. A word like `level:loud` is an error
(`LogFilterError`, the text says what would be understood); the pane keeps the
previous filter.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

from rich.text import Text

LEVELS = {"debug": logging.DEBUG, "info": logging.INFO, "warning": logging.WARNING,
          "error": logging.ERROR, "critical": logging.CRITICAL}


class LogFilterError(ValueError):
    """A filter that cannot be understood; the text says why."""


@dataclass(frozen=True)
class LogEntry:
    """One line of the log pane."""

    text: Text
    level: int = logging.INFO
    component: str = ""

    @property
    def plain(self) -> str:
        return self.text.plain

    @property
    def searchable(self) -> str:
        """The text the filter's words look in: the line without its time stamp."""
        return self.text.plain.partition(" ")[2].lower()


def level_of(name: str) -> int:
    """`logging` level of a name or its prefix (`WARN`, `w`, `Error`); INFO if unknown."""
    name = name.strip().lower()
    for known, value in LEVELS.items():
        if name and known.startswith(name):
            return value
    return logging.INFO


@dataclass(frozen=True)
class LogFilter:
    """What the operator typed after `/`, parsed."""

    text: str = ""
    level: int = logging.NOTSET
    components: tuple[str, ...] = ()
    words: tuple[str, ...] = ()

    @classmethod
    def parse(cls, text: str) -> LogFilter:
        level, components, words = logging.NOTSET, [], []
        for word in text.lower().split():
            key, sep, value = word.partition(":")
            if word.startswith("@") and len(word) > 1:
                components.append(word[1:])
            elif sep and key in ("level", "l", "lvl"):
                found = [v for k, v in LEVELS.items() if value and k.startswith(value)]
                if not found:
                    raise LogFilterError(f"unknown level {value!r}; use one of "
                                         f"{', '.join(LEVELS)} (or a prefix: level:warn)")
                level = found[0]
            elif sep and key in ("comp", "c", "component"):
                if not value:
                    raise LogFilterError("comp: needs a component name, e.g. comp:rcl")
                components.append(value)
            else:
                words.append(word)
        return cls(text.strip(), level, tuple(components), tuple(words))

    @property
    def active(self) -> bool:
        return bool(self.level or self.components or self.words)

    def matches(self, entry: LogEntry) -> bool:
        if entry.level < self.level:
            return False
        component = entry.component.lower()
        if self.components and not any(c in component for c in self.components):
            return False
        text = entry.searchable
        return all(word in text for word in self.words)
