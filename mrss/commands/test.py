"""`mrss test PROJECT [PYTEST ARGS]`: run a project's test procedures with pytest.

The procedures are the pytest files in `projects/<PROJECT>/procedures/`. pytest runs in
a child process (`python -P -m pytest <procedures> PYTEST ARGS`, in the current
directory), with `MRSS_PROJECT` (the name) and `MRSS_PROJECT_DIR` (the folder) in its
environment so procedures can find their project. The exit code is pytest's (0 all
passed, 1 some failed, 5 none collected, ...). An unknown project, or one without a
procedures folder, exits 2.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys

from mrss.config.projects import project_path
from mrss.errors import UnknownProjectError
from mrss.interpreter import python_module

EXIT_USAGE = 2
PROCEDURES = "procedures"


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("project", help="project name (projects/<name>/)")
    parser.add_argument("pytest_args", nargs=argparse.REMAINDER, metavar="PYTEST ARGS",
                        help="passed on to pytest, e.g. -k NAME, -x, -q")


def run(args: argparse.Namespace) -> int:
    try:
        project = project_path(args.project)
    except UnknownProjectError as exc:
        print(f"mrss test: {exc}", file=sys.stderr)
        return EXIT_USAGE
    procedures = project / PROCEDURES
    if not procedures.is_dir():
        print(f"mrss test: project {args.project!r} has no {PROCEDURES}/ folder "
              f"({procedures})", file=sys.stderr)
        return EXIT_USAGE
    extra: list[str] = list(args.pytest_args)
    if extra[:1] == ["--"]:
        extra = extra[1:]
    env = dict(os.environ, MRSS_PROJECT=args.project, MRSS_PROJECT_DIR=str(project))
    try:
        done = subprocess.run(python_module("pytest", str(procedures), *extra),
                              env=env, check=False)
    except KeyboardInterrupt:
        return 130
    return done.returncode
