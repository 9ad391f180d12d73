"""Import a project's module (events.py, datalayer.py, ...) from its folder, and only from there.

`load_project_class(project_dir, "events.py", ExternalAdapter)` imports the file under a
private module name and returns the one subclass of the base it defines (or the class
named by `class_name`). A path that resolves outside the project folder — `../x.py`,
an absolute path, a symlink pointing out — is refused with a ConfigError, as is a file
that is missing, not Python, fails to import (with its line), or defines no such class.
"""

from __future__ import annotations

import importlib.util
import re
import sys
import traceback
from pathlib import Path
from types import ModuleType
from typing import TypeVar

from mrss.errors import ConfigError

T = TypeVar("T")
_SAFE = re.compile(r"[^A-Za-z0-9_]")


def project_file(project_dir: Path, relative: str, *, key: str | None = None) -> Path:
    """The resolved path of `relative` inside `project_dir`; ConfigError if it leaves it."""
    root = project_dir.resolve()
    candidate = Path(relative)
    if candidate.is_absolute():
        raise ConfigError(f"refused {relative!r}: project modules are given relative to the "
                          f"project folder {root}", key=key)
    path = (root / candidate).resolve()
    if not path.is_relative_to(root):
        raise ConfigError(f"refused {relative!r}: it resolves to {path}, outside the project "
                          f"folder {root}", key=key)
    return path


def import_project_module(project_dir: Path, relative: str, *,
                          key: str | None = None) -> ModuleType:
    """Import one Python file of the project (a fresh module object every call)."""
    path = project_file(project_dir, relative, key=key)
    if path.suffix != ".py":
        raise ConfigError(f"{relative!r} is not a .py file", file=str(path), key=key)
    if not path.is_file():
        raise ConfigError("no such file", file=str(path), key=key)
    root = project_dir.resolve()
    name = "mrss_project_" + _SAFE.sub("_", f"{root.name}__{path.relative_to(root)}")[:-3]
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:
        raise ConfigError("cannot be imported", file=str(path), key=key)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # dataclasses and pickling look classes up here
    try:
        spec.loader.exec_module(module)
    except SyntaxError as exc:
        sys.modules.pop(name, None)
        raise ConfigError(f"syntax error: {exc.msg}",
                          file=f"{path}:{exc.lineno}" if exc.lineno else str(path)) from exc
    except Exception as exc:
        sys.modules.pop(name, None)
        line = _line_in(exc, path)
        raise ConfigError(f"import failed: {exc.__class__.__name__}: {exc}",
                          file=f"{path}:{line}" if line else str(path)) from exc
    return module


def _line_in(exc: BaseException, path: Path) -> int | None:
    frames = [f for f in traceback.extract_tb(exc.__traceback__)
              if Path(f.filename).resolve() == path]
    return frames[-1].lineno if frames else None


def load_project_class(project_dir: Path, relative: str, base: type[T], *,
                       class_name: str | None = None, key: str | None = None) -> type[T]:
    """The subclass of `base` that the project file defines (exactly one, or `class_name`)."""
    module = import_project_module(project_dir, relative, key=key)
    where = str(project_file(project_dir, relative))
    if class_name:
        found = getattr(module, class_name, None)
        if not (isinstance(found, type) and issubclass(found, base)):
            raise ConfigError(f"{class_name!r} is not a subclass of {base.__name__}",
                              file=where, key=key)
        return found
    candidates = [obj for obj in vars(module).values()
                  if isinstance(obj, type) and issubclass(obj, base) and obj is not base
                  and obj.__module__ == module.__name__]
    if not candidates:
        raise ConfigError(f"defines no subclass of {base.__name__}", file=where, key=key)
    if len(candidates) > 1:
        names = ", ".join(sorted(c.__name__ for c in candidates))
        raise ConfigError(f"defines several subclasses of {base.__name__} ({names}); "
                          "name one with the 'class' option", file=where, key=key)
    return candidates[0]
