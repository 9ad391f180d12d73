"""Parse AgentSpeak source into a `Program`, reporting every syntax error of the file.

The source is first split into statements at each top-level terminating `.` (outside
brackets, strings and comments, and followed by white space or the end); each
statement is parsed on its own with the LALR grammar in `grammar.lark`, so one bad
statement does not hide the errors of the others.

lark (and the tree builder made on it) is imported when a statement is first parsed
with the grammar, not with this module: a literal the fast reader takes (a percept, a
goal pattern in project.toml) needs neither, and the root supervisor, which reads such
patterns, then never holds the parser's megabytes.
"""

from __future__ import annotations

import functools
import os
import re
import sys
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from mrss import usercache
from mrss.agentspeak.depth import PARSE_DEPTH, deep_recursion
from mrss.agentspeak.errors import AslRuntimeError, AslSyntaxError, SyntaxProblem
from mrss.agentspeak.fastread import read_simple
from mrss.agentspeak.syntax import BeliefSrc, Program
from mrss.agentspeak.terms import Struct, Term
from mrss.agentspeak.unify import resolve

if TYPE_CHECKING:
    import lark

_TOKEN_TEXT = {
    "DOT": ".", "SEMICOLON": ";", "COMMA": ",", "LPAR": "(", "RPAR": ")", "LSQB": "[",
    "RSQB": "]", "LBRACE": "{", "RBRACE": "}", "COLON": ":", "ARROW": "<-",
    "RULE_ARROW": ":-", "AMPERSAND": "&", "VBAR": "|", "BANG": "!", "BANGBANG": "!!",
    "QMARK": "?", "MINUS": "-", "NEG": "~", "AT": "@", "ATOM": "an atom",
    "VAR": "a variable", "NUMBER": "a number", "STRING": "a string",
    "IA_NAME": "an internal action", "TRIGGER_OP": "a triggering event",
    "REL_OP": "a relational operator", "PLUS": "+", "MUL_OP": "*, /, div or mod",
    "ADD_BEL_OP": "+< or +>", "REPLACE_OP": "-+", "POW": "**", "$END": "end of statement",
    "NS": "a namespace",
}


def _cache_file() -> str | bool:
    """Where lark keeps the parser tables it builds from the grammar (building them is
    most of the start-up of `mrss agent`): a folder of this user only, never a shared
    temporary folder (the cache is a pickle). False (no cache) when it cannot be made."""
    import lark

    try:
        folder = usercache.folder()
        folder.mkdir(mode=0o700, parents=True, exist_ok=True)
        if folder.stat().st_uid != os.getuid() or folder.stat().st_mode & 0o022:
            return False
    except (OSError, RuntimeError):  # RuntimeError: no home folder
        return False
    return str(folder / f"agentspeak-grammar-lark{lark.__version__}-py"
                        f"{sys.version_info[0]}{sys.version_info[1]}.cache")


@functools.lru_cache(maxsize=1)
def _lark() -> lark.Lark:
    import lark

    grammar = (Path(__file__).parent / "grammar.lark").read_text(encoding="utf-8")
    # the cache holds a digest of the grammar and options: a changed grammar rebuilds it;
    # an unreadable or half-written one is rebuilt too (lark logs nothing at its level)
    return lark.Lark(grammar, parser="lalr", propagate_positions=True, maybe_placeholders=True,
                     cache=_cache_file())


def warm() -> None:
    """Build the parser now. The fork server does (`mrss.runtime.forkserver.WARM`), so the
    processes it forks share its parser instead of each loading one of its own."""
    import mrss.agentspeak.builder  # noqa: F401 (shared with the forked, as lark is)

    _lark()


# ------------------------------------------------------------------------------ splitting

def split_statements(text: str) -> list[tuple[int, int]]:
    """(start, end) offsets of each statement, the terminating `.` included."""
    spans: list[tuple[int, int]] = []
    i, n, start = 0, len(text), 0
    while i < n:
        c = text[i]
        if c == '"':
            i += 1
            while i < n and text[i] != '"' and text[i] != "\n":
                i += 2 if text[i] == "\\" else 1
        elif c == "/" and text.startswith("//", i):
            j = text.find("\n", i)
            i = n if j < 0 else j
            continue
        elif c == "/" and text.startswith("/*", i):
            j = text.find("*/", i + 2)
            i = n if j < 0 else j + 2
            continue
        elif c == "." and (i + 1 == n or text[i + 1] in " \t\r\n/"):
            # a dot before white space ends a statement even inside unbalanced brackets
            # (it is valid nowhere else), so an unclosed `(` cannot swallow the file
            spans.append((start, i + 1))
            start = i + 1
        i += 1
    if text[start:].strip() and _has_code(text[start:]):
        spans.append((start, n))
    return spans


def _has_code(rest: str) -> bool:
    """Whether a trailing piece holds more than comments and white space."""
    return _code_start(rest) < len(rest)


def _code_start(rest: str) -> int:
    """The offset of the first character that is not white space or in a comment."""
    i = 0
    while i < len(rest):
        if rest.startswith("//", i):
            j = rest.find("\n", i)
            i = len(rest) if j < 0 else j
        elif rest.startswith("/*", i):
            j = rest.find("*/", i + 2)
            i = len(rest) if j < 0 else j + 2
        elif rest[i].isspace():
            i += 1
        else:
            return i
    return i



# ------------------------------------------------------------------------------ parsing

def _position(text: str, offset: int) -> tuple[int, int]:
    line = text.count("\n", 0, offset) + 1
    col = offset - (text.rfind("\n", 0, offset) + 1) + 1
    return line, col


def _describe(exc: lark.exceptions.LarkError) -> str:
    import lark

    if isinstance(exc, lark.exceptions.UnexpectedToken):
        tok = exc.token
        got = "end of statement" if tok.type == "$END" else repr(str(tok))
        names = sorted({_TOKEN_TEXT.get(e, e.lower() if not e.startswith("__") else e)
                        for e in exc.expected if not e.startswith("__ANON")})
        shown = ", ".join(f'"{n}"' if len(n) <= 3 else n for n in names[:8])
        return f"unexpected {got}" + (f"; expected {shown}" if shown else "")
    if isinstance(exc, lark.exceptions.UnexpectedCharacters):
        return f"unexpected character {exc.char!r}"
    if isinstance(exc, lark.exceptions.UnexpectedEOF):
        return "unexpected end of statement"
    return str(exc)


def _closing_brace(chunk: str, i: int) -> int | None:
    """Offset of the `}` closing the `{` at `i` (strings skipped), or None."""
    depth = 0
    while i < len(chunk):
        c = chunk[i]
        if c == '"':
            j = chunk.find('"', i + 1)
            while j > 0 and chunk[j - 1] == "\\":
                j = chunk.find('"', j + 1)
            if j < 0:
                return None
            i = j
        elif c == "{":
            depth += 1
        elif c == "}":
            depth -= 1
            if depth == 0:
                return i
        i += 1
    return None


def _unsupported(chunk: str, exc: lark.exceptions.UnexpectedInput) -> str | None:
    """A message naming the Jason construct that is not supported, when the syntax
    error is where one starts."""
    pos = getattr(exc, "pos_in_stream", None)
    if pos is None or pos < 0 or pos >= len(chunk):
        return None
    here = chunk[pos:pos + 3]
    if here.startswith("^"):
        return "goal-state meta-events of test goals (^?g) are not supported; ^!g is"
    if here in ("|&|", "|||"):
        return "fork and join (|&| and |||) are not supported"
    if here.startswith("::"):
        return _namespace_before(chunk[:pos])
    after_ns = _AFTER_NS.search(chunk[:pos])
    if after_ns is not None:
        ns = after_ns.group(1)
        c = chunk[pos]
        what = ("a variable" if c.isupper() or c == "_" else "a string" if c == '"'
                else "a list" if c == "[" else "a number" if c.isdigit() else None)
        if what is not None:
            return (f"a namespace prefixes a literal ({ns}::b); {what} after it is not "
                    f"supported")
    return None


_BEFORE_NS = re.compile(r"(::)?(~?)([A-Za-z_][A-Za-z0-9_]*)?\s*$")
_AFTER_NS = re.compile(r"([a-z][A-Za-z0-9_]*)::\s*$")


def _namespace_before(before: str) -> str:
    """Why `::` cannot come after `before` (the text up to it)."""
    m = _BEFORE_NS.search(before)
    name = m.group(3) if m is not None else None
    if m is not None and m.group(1) and name:
        return "a literal has one namespace (ns::b), not several"
    if name is None:
        return ("`::b` names the local namespace of a module, and modules of namespaces "
                "({ begin namespace(ns) }) are not supported: write ns::b")
    if name[0].isupper() or name[0] == "_":
        return (f"variable namespaces ({name}::b) are not supported: a namespace is an "
                f"atom (ns::b)")
    if m is not None and m.group(2):
        return f"the strong negation goes after the namespace: {name}::~b, not ~{name}::b"
    return f"a namespace must be an atom (ns::b), not {name}"


def _restart_offset(chunk: str, exc: lark.exceptions.UnexpectedInput) -> int | None:
    """Where to resume after an error inside `chunk`, if a new statement probably starts
    there: the offending token itself when it opens its line (a missing `.`), else the
    next line that starts in column 1 with a plan, goal or label."""
    pos = getattr(exc, "pos_in_stream", None)
    line = getattr(exc, "line", None)
    if pos is None or line is None or pos <= 0:
        return None
    if line > 1 and not chunk[chunk.rfind("\n", 0, pos) + 1:pos].strip():
        return int(pos)
    nl = chunk.find("\n", pos)
    while nl >= 0 and nl + 1 < len(chunk):
        if chunk[nl + 1] in "+-@!" and chunk[nl + 1:].strip():
            return nl + 1
        nl = chunk.find("\n", nl + 1)
    return None


_INCLUDE = re.compile(r'\{\s*include\s*\(\s*"((?:[^"\\\n]|\\.)*)"\s*\)\s*\}')
MAX_INCLUDE_DEPTH = 20


def _include(name: str, file: str, depth: int, add: Callable[[str], None],
             problems: list[SyntaxProblem], program: Program) -> None:
    """Parse the file `{include("name")}` names, relative to the including file, and
    append its statements."""
    base = Path(file).parent if not file.startswith("<") else Path.cwd()
    path = base / name
    if depth >= MAX_INCLUDE_DEPTH:
        add(f"include {name!r}: more than {MAX_INCLUDE_DEPTH} nested includes "
            f"(a file including itself?)")
        return
    try:
        data = path.read_bytes()
    except OSError as exc:
        add(f"cannot include {name!r}: {exc.strerror or exc} ({path})")
        return
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        add(f"cannot include {name!r}: not UTF-8 text (byte offset {exc.start})")
        return
    inner = parse_program(text, str(path), collect=problems, _depth=depth + 1)
    for st in inner.statements:
        if st.file is None:
            st.file = str(path)
        program.statements.append(st)


TERM_FILE = "<term>"  # what `parse_term` parses: terms read at run time
_TREES: dict[str, lark.Tree[Any]] = {}  # statement text -> its parse tree
MAX_TREES = 1024


def _tree(chunk: str, keep: bool) -> lark.Tree[Any]:
    """The parse tree of one statement's text; with `keep` (a program's statement, not
    a term read at run time), parsed once per process: many agents of one program (a
    society of a thousand) parse it once, and build their statements from the same
    tree (`TreeBuilder` makes new objects; the tree is not changed)."""
    tree = _TREES.get(chunk)
    if tree is None:
        tree = _lark().parse(chunk)
        if not keep:
            return tree
        if len(_TREES) >= MAX_TREES:
            _TREES.clear()
        _TREES[chunk] = tree
    return tree


def parse_program(text: str, file: str = "<string>",
                  collect: list[SyntaxProblem] | None = None, _depth: int = 0) -> Program:
    """Parse a whole source; raise `AslSyntaxError` listing every error found (or, with
    `collect`, append them there and return the statements that parsed).
    `{include("f.asl")}` parses f.asl (relative to `file`) in its place."""
    import lark

    from mrss.agentspeak.builder import TreeBuilder

    lines = text.splitlines()
    problems: list[SyntaxProblem] = [] if collect is None else collect
    program = Program(file)

    def add(line: int, col: int, message: str) -> None:
        src = lines[line - 1] if 0 < line <= len(lines) else ""
        problems.append(SyntaxProblem(file, line, col, message, src.rstrip("\r")))

    pending = list(reversed(split_statements(text)))
    while pending:
        start, end = pending.pop()
        chunk = text[start:end]
        line0, col0 = _position(text, start)
        local: list[tuple[int, int, str]] = []
        statement = None
        lead = _code_start(chunk)
        if chunk[lead:lead + 1] == "{":  # a directive has no `.`: do it, parse the rest
            close = _closing_brace(chunk, lead)
            line, col = _position(chunk, lead)
            here = (line0 + line - 1, col + (col0 - 1 if line == 1 else 0))
            inc = _INCLUDE.match(chunk, lead)
            if inc is not None and close is not None and inc.end() == close + 1:
                _include(inc.group(1), file, _depth, functools.partial(add, *here), problems,
                         program)
            else:
                add(here[0], here[1], "directives other than {include(\"file.asl\")} "
                                      "({begin ...}, ...) are not supported")
            if close is not None and chunk[close + 1:].strip():
                pending.append((start + close + 1, end))
            continue
        try:
            with deep_recursion():
                tree = _tree(chunk, file != TERM_FILE)
                statement = TreeBuilder(line0, local, col0).transform(tree)
        except RecursionError:
            line, col = _position(chunk, len(chunk) - len(chunk.lstrip()))
            local.append((line, col, f"a term is nested too deeply (more than about "
                                     f"{PARSE_DEPTH} levels)"))
        except lark.exceptions.UnexpectedInput as exc:
            line = getattr(exc, "line", -1)
            col = getattr(exc, "column", -1)
            if line is None or line < 1:  # end of input: point just past the chunk
                line, col = _position(chunk, len(chunk.rstrip()))
                col += 1
            local.append((line, col, _unsupported(chunk, exc) or _describe(exc)))
            restart = _restart_offset(chunk, exc)
            if restart is not None:  # probably a missing `.`: parse the rest on its own
                pending.append((start + restart, end))
        except lark.exceptions.VisitError as exc:
            local.append((1, 1, f"invalid statement: {exc.orig_exc}"))
        for line, col, message in local:
            add(line0 + line - 1, col + (col0 - 1 if line == 1 else 0), message)
        if statement is not None and not local:
            program.statements.append(statement)
    if problems and collect is None:
        raise AslSyntaxError(problems)
    return program


def parse_term(text: str) -> Term:
    """A runtime term from text such as `area_goal_received(g1, 3)` (variables free)."""
    program = parse_program(text.strip().rstrip(".") + ".", TERM_FILE)
    if len(program.statements) != 1 or not isinstance(program.statements[0], BeliefSrc):
        raise AslSyntaxError([SyntaxProblem(TERM_FILE, 1, 1, "expected one literal", text)])
    lit = program.statements[0].lit
    if lit.ground:
        return lit
    try:
        return resolve(lit, [None] * 64)
    except AslRuntimeError as exc:  # e.g. b(X+1): arithmetic on an unbound variable
        raise AslSyntaxError([SyntaxProblem(TERM_FILE, 1, 1, exc.message, text)]) from None


def parse_literal(text: str | Struct) -> Struct:
    """A literal from text (or a `Struct` passed through), e.g. for percepts."""
    if isinstance(text, Struct):
        return text
    simple = read_simple(text)
    if simple is not None:
        return simple
    t = parse_term(text)
    assert isinstance(t, Struct)
    return t
