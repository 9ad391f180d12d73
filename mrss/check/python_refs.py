"""What the project's Python files state about each other, and that each of them compiles.

Project files reach each other only through `NAME = import_project_module(DIR,
"file.py")` (mrss.api); every such file is read, procedures and helper scripts
included (they are parsed, never imported here):
- every file of the project folder compiles (`compile`, so `return` outside a function
  counts too), at its line and column with a caret;
- `"file.py"` is a file of the project folder;
- every `NAME.attr` is defined by file.py (its top-level definitions and imports);
- every call `NAME.attr(...)` fits the signature of what it calls (a class: its
  constructor), when the calling file was imported by the check (rcl.py, skills.py,
  events.py, datalayer.py and what they import), so the callee is a real object.
A problem already reported at the same place, or in a file whose import failed, is not
reported again.
"""

from __future__ import annotations

import ast
import inspect
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType

from mrss.check.findings import Report, did_you_mean
from mrss.check.sources import Sources
from mrss.textfile import NotUtf8Error, read_text

LOADER = "import_project_module"
SKIPPED = frozenset({"__pycache__", ".venv", ".git"})


@dataclass
class ParsedFile:
    path: Path
    tree: ast.Module
    module: ModuleType | None  # when the check imported it


def project_python_files(project_dir: Path) -> list[Path]:
    return sorted(p for p in project_dir.rglob("*.py")
                  if not SKIPPED & set(p.relative_to(project_dir).parts))


def check_python_refs(sources: Sources, report: Report) -> None:
    """Every rule of the module docstring, over every Python file of the project folder."""
    parsed: dict[Path, ParsedFile] = {}
    for path in project_python_files(sources.project_dir):
        loaded = sources.loaded.get(path.resolve())
        if loaded is not None and (loaded.broken or loaded.tree is None):
            continue  # its own finding says why
        tree = loaded.tree if loaded is not None else _compiled(path, report)
        if tree is not None:
            parsed[path.resolve()] = ParsedFile(path, tree, loaded.module if loaded else None)
    for file in parsed.values():
        for name, target, node in _bindings(file.tree):
            _check_binding(sources, parsed, file, name, target, node, report)


def _compiled(path: Path, report: Report) -> ast.Module | None:
    try:
        text = read_text(path)
    except (OSError, NotUtf8Error) as exc:
        report.error(str(path), getattr(exc, "reason", None) or f"cannot read: {exc}",
                     check="python")
        return None
    try:
        compile(text, str(path), "exec", dont_inherit=True)
        return ast.parse(text, filename=str(path))
    except SyntaxError as exc:
        if _already(report, path):
            return None
        lines = text.splitlines()
        line = exc.lineno or 0
        src = lines[line - 1] if 0 < line <= len(lines) else ""
        caret = " " * (max(exc.offset or 1, 1) - 1) + "^"
        report.error(str(path), f"syntax error: {exc.msg}", line=line, col=exc.offset or 0,
                     check="python", detail=f"    {src}\n    {caret}" if src else "")
        return None


def _already(report: Report, path: Path) -> bool:
    """Whether a finding already names this file (e.g. the import of a file that uses it)."""
    text = str(path)
    return any(f.file == text or text in f.message for f in report.findings)


def _bindings(tree: ast.Module) -> Iterator[tuple[str, str, ast.Call]]:
    """`NAME = import_project_module(..., "file.py")` anywhere in the file."""
    for node in ast.walk(tree):
        if isinstance(node, ast.Assign) and len(node.targets) == 1 \
                and isinstance(node.targets[0], ast.Name) and isinstance(node.value, ast.Call):
            call = node.value
            func = call.func
            called = func.id if isinstance(func, ast.Name) else \
                func.attr if isinstance(func, ast.Attribute) else ""
            if called == LOADER and len(call.args) >= 2 \
                    and isinstance(call.args[1], ast.Constant) \
                    and isinstance(call.args[1].value, str):
                yield node.targets[0].id, call.args[1].value, call


def _check_binding(sources: Sources, parsed: dict[Path, ParsedFile], file: ParsedFile,
                   name: str, target: str, node: ast.Call, report: Report) -> None:
    where = str(file.path)
    path = (sources.project_dir / target).resolve()
    if not path.is_relative_to(sources.project_dir.resolve()) or not path.is_file():
        if not any(f.file == where and f.line == node.lineno for f in report.findings):
            report.error(where, f"{LOADER}(..., {target!r}): no such file in the project "
                         "folder", line=node.lineno, col=node.col_offset + 1, check="python")
        return
    other = parsed.get(path)
    if other is None:
        return  # broken, and reported as such
    module = getattr(file.module, name, None) if file.module is not None else None
    defined = _defined(other.tree)
    for attr in ast.walk(file.tree):
        if not (isinstance(attr, ast.Attribute) and isinstance(attr.value, ast.Name)
                and attr.value.id == name):
            continue
        line, col = attr.lineno, attr.end_col_offset - len(attr.attr) + 1 \
            if attr.end_col_offset is not None else attr.col_offset + 1
        if defined is not None and attr.attr not in defined \
                and not any(f.file == where and f.line == line for f in report.findings):
            report.error(where, f"{name}.{attr.attr}: {target} defines no {attr.attr!r}"
                         + did_you_mean(attr.attr, defined, what="it defines"),
                         line=line, col=col, check="python")
    if isinstance(module, ModuleType):
        _check_calls(file, name, module, target, report)


def _defined(tree: ast.Module) -> set[str] | None:
    """The names a module defines at its top level; None when it cannot be told."""
    names: set[str] = set()
    todo: list[ast.stmt] = list(tree.body)
    while todo:
        node = todo.pop()
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
            names.add(node.name)
            if node.name == "__getattr__":
                return None
        elif isinstance(node, ast.Assign | ast.AnnAssign | ast.AugAssign):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            for t in targets:
                names |= {n.id for n in ast.walk(t) if isinstance(n, ast.Name)}
        elif isinstance(node, ast.Import | ast.ImportFrom):
            for alias in node.names:
                if alias.name == "*":
                    return None
                names.add(alias.asname or alias.name.partition(".")[0])
        elif isinstance(node, ast.If | ast.Try | ast.With | ast.For | ast.While):
            for field in ("body", "orelse", "finalbody", "handlers"):
                todo += [n for n in getattr(node, field, []) if isinstance(n, ast.stmt)]
                for handler in getattr(node, field, []):
                    if isinstance(handler, ast.ExceptHandler):
                        todo += handler.body
    return names


def _check_calls(file: ParsedFile, name: str, module: ModuleType, target: str,
                 report: Report) -> None:
    where = str(file.path)
    for call in ast.walk(file.tree):
        if not (isinstance(call, ast.Call) and isinstance(call.func, ast.Attribute)
                and isinstance(call.func.value, ast.Name) and call.func.value.id == name):
            continue
        if any(isinstance(a, ast.Starred) for a in call.args) \
                or any(k.arg is None for k in call.keywords):
            continue  # *args / **kwargs: not told statically
        callee = getattr(module, call.func.attr, None)
        if callee is None or not callable(callee):
            continue
        try:
            signature = inspect.signature(callee)
        except (TypeError, ValueError):
            continue
        keywords = [k.arg for k in call.keywords if k.arg is not None]
        try:
            signature.bind(*call.args, **dict.fromkeys(keywords))
        except TypeError as exc:
            params = [p for p in signature.parameters if p != "self"]
            bad = [k for k in keywords if k not in signature.parameters]
            hint = did_you_mean(bad[0], params) if bad else ""
            line = _line_of(callee)
            plain = ", ".join(p for p in signature.parameters)
            report.error(where, f"{name}.{call.func.attr}(...) does not fit "
                         f"{call.func.attr}({plain}) ({target}"
                         + (f":{line}" if line else "") + f"): {exc}"
                         + (hint if hint.startswith("; did you mean") else ""),
                         line=call.lineno, col=call.col_offset + 1, check="python")


def _line_of(obj: object) -> int:
    try:
        return inspect.getsourcelines(obj)[1]  # type: ignore[arg-type]
    except (OSError, TypeError):
        return 0
