"""The command line of every Python process MRSS starts: `python -P -m MODULE ARGS`.

`python -m MODULE` puts the working directory first on the new process's `sys.path`, so
a folder named `mrss` there (a checkout of this repository, whose top folder is a
namespace package to Python, or another package of that name) is imported instead of
the installed MRSS: every component would crash-loop with `ImportError ... mrss.projects
(unknown location)` while `mrss check`, an entry-point script, passes. `-P` (Python 3.11+,
the same as `PYTHONSAFEPATH=1`) leaves the working directory off `sys.path`; the child
finds `mrss` where the installation put it (site-packages, or the editable install's
finder), and a component's own modules come from its project folder, which the
component runner puts on `sys.path` itself.
"""

from __future__ import annotations

import sys

SAFE_PATH = "-P"  # do not prepend the working directory (or a script's folder) to sys.path


def python_module(module: str, *args: str, python: str = sys.executable) -> list[str]:
    """The argv that runs `module` as `__main__` in a fresh interpreter, cwd-proof."""
    return [python, SAFE_PATH, "-m", module, *args]
