"""The project's Python files as `mrss check` sees them: parsed, imported, their classes.

Rules:
- a file is parsed with `ast` first: a syntax error is one finding at its line and
  column (with a caret), and the file is not imported;
- then it is imported from the project folder (`mrss.runtime.loader`); an exception is one
  finding at the deepest line of that file in the traceback;
- a file whose import failed only because a file it imports is broken (that file's path
  is in the error or its traceback) gets no finding of its own but a note that it was
  not checked: one mistake, one error (no cascades);
- a class asked for by name that the file does not define is reported with the classes
  the file does define ("did you mean").
"""

from __future__ import annotations

import ast
import inspect
import traceback
from dataclasses import dataclass, field
from pathlib import Path
from types import ModuleType
from typing import Any

from mrss.check.findings import Report, did_you_mean
from mrss.errors import ConfigError
from mrss.runtime.loader import import_project_module, project_file
from mrss.textfile import NotUtf8Error, read_text


@dataclass
class PySource:
    """One project file: its syntax tree and module, or why it has neither."""

    path: Path
    tree: ast.Module | None = None
    module: ModuleType | None = None
    broken: bool = False  # a finding already says why; dependants are not checked

    def class_node(self, name: str) -> ast.ClassDef | None:
        if self.tree is None:
            return None
        for node in self.tree.body:
            if isinstance(node, ast.ClassDef) and node.name == name:
                return node
        return None

    def classes(self, base: type) -> list[type]:
        """The subclasses of `base` this file defines (not those it imports)."""
        if self.module is None:
            return []
        return [c for _, c in inspect.getmembers(self.module, inspect.isclass)
                if issubclass(c, base) and c is not base
                and c.__module__ == self.module.__name__]

    def line_of(self, obj: Any) -> int:
        try:
            return inspect.getsourcelines(obj)[1]
        except (OSError, TypeError):
            return 0


@dataclass
class Sources:
    """Every project file loaded so far in one check, by resolved path."""

    project_dir: Path
    report: Report
    loaded: dict[Path, PySource] = field(default_factory=dict)

    def load(self, relative: str, *, check: str, key: str | None = None,
             key_file: str = "", key_line: int = 0) -> PySource:
        """Parse and import `relative` once per check; findings go to the report."""
        try:
            path = project_file(self.project_dir, relative, key=key)
        except ConfigError as exc:
            self.report.error(key_file, exc.reason, line=key_line, check=check, key=key)
            return PySource(Path(relative), broken=True)
        if path in self.loaded:
            return self.loaded[path]
        source = self.loaded[path] = PySource(path)
        if not path.is_file():
            self.report.error(key_file or str(path), f"{relative!r}: no such file in the "
                              "project folder", line=key_line, check=check, key=key)
            source.broken = True
            return source
        try:
            text = read_text(path)
        except (OSError, NotUtf8Error) as exc:
            line = exc.line if isinstance(exc, NotUtf8Error) else 0
            why = exc.reason if isinstance(exc, NotUtf8Error) else f"cannot read: {exc}"
            self.report.error(str(path), why, line=line, check=check)
            source.broken = True
            return source
        try:
            source.tree = ast.parse(text, filename=str(path))
        except SyntaxError as exc:
            lines = text.splitlines()
            line = exc.lineno or 0
            src = lines[line - 1] if 0 < line <= len(lines) else ""
            caret = " " * (max(exc.offset or 1, 1) - 1) + "^"
            self.report.error(str(path), f"syntax error: {exc.msg}", line=line,
                              col=exc.offset or 0, check=check,
                              detail=f"    {src}\n    {caret}" if src else "")
            source.broken = True
            return source
        try:
            source.module = import_project_module(self.project_dir, relative, key=key)
        except ConfigError as exc:
            cause = exc.__cause__
            blamed = self._broken_dependency(exc, cause)
            if blamed is not None:
                self.report.warning(str(path), f"not checked: it imports {blamed.name}, "
                                    "which has an error reported above", check=check)
            else:
                self.report.error(str(path), f"import failed: {_describe(cause or exc)}",
                                  line=_line_in(cause, path), check=check)
            source.broken = True
        return source

    def _broken_dependency(self, exc: ConfigError, cause: BaseException | None) -> Path | None:
        text = str(exc)
        frames = {Path(f.filename).resolve() for f in
                  traceback.extract_tb(cause.__traceback__)} if cause else set()
        for path, other in self.loaded.items():
            if other.broken and (str(path) in text or path in frames):
                return path
        return None

    def find_class(self, source: PySource, base: type, class_name: str | None, *,
                   check: str, key: str, key_file: str, key_line: int) -> type | None:
        """The class named `class_name`, else the one subclass of `base`; findings if not."""
        defined = source.classes(base)
        if class_name:
            found = getattr(source.module, class_name, None)
            if isinstance(found, type) and issubclass(found, base):
                return found
            names = [c.__name__ for c in defined]
            what = (f"is a {type(found).__name__}, not a subclass of {base.__name__}"
                    if found is not None else f"is not defined in {source.path.name}")
            self.report.error(key_file, f"class {class_name!r} {what}"
                              + (did_you_mean(class_name, names, what=f"{source.path.name} "
                                              f"defines the {base.__name__} subclasses")
                                 or f"; {source.path.name} defines no {base.__name__} "
                                    "subclass"),
                              line=key_line, check=check, key=key)
            return None
        if len(defined) == 1:
            return defined[0]
        if not defined:
            self.report.error(str(source.path), f"defines no subclass of {base.__name__} "
                              f"(expected exactly one, or name it with {key!r})", check=check)
        else:
            listing = ", ".join(sorted(c.__name__ for c in defined))
            self.report.error(str(source.path), f"defines several subclasses of "
                              f"{base.__name__} ({listing}): name one with {key!r}",
                              line=source.line_of(defined[1]), check=check)
        return None


def _describe(exc: BaseException) -> str:
    if isinstance(exc, ConfigError):
        return str(exc)
    return f"{exc.__class__.__name__}: {exc}"


def _line_in(exc: BaseException | None, path: Path) -> int:
    if exc is None:
        return 0
    frames = [f for f in traceback.extract_tb(exc.__traceback__)
              if Path(f.filename).resolve() == path.resolve()]
    return frames[-1].lineno or 0 if frames else 0
