"""`mrss new NAME [--from PROJECT | --with-sims]`: a new project folder, copied from the template.

`--with-sims` copies the template's variant wired to the two built-in simulators
(`template_sims`: a MAVLink UAV and an MQTT UGV, with recipes and skills that move them);
it is `--from template_sims`, and refused together with another `--from`.

The copy goes to the projects folder (`$MRSS_PROJECTS`, ./projects, or the source
tree's). What carries the source's name is renamed: `[project] name` in project.toml,
and procedure files named after it (`procedures/test_template.py` ->
`procedures/test_NAME.py`, so pytest never sees two test modules of one name).
Refused with exit 2 and a message: a name that is not a lowercase identifier, a folder
that already exists, an unknown source project.
"""

from __future__ import annotations

import argparse
import re
import shutil
import sys
from pathlib import Path

from mrss.config.projects import PROJECT_FILE, known_projects, project_path, projects_dir
from mrss.errors import UnknownProjectError

EXIT_REFUSED = 2
NAME = re.compile(r"[a-z][a-z0-9_]{0,63}\Z")
IGNORED = shutil.ignore_patterns("__pycache__", "*.pyc", ".pytest_cache", ".mypy_cache",
                                 ".ruff_cache", "run", "*.sqlite*")
WITH_SIMS = "template_sims"
SOURCE_TREE_PROJECTS = Path(__file__).resolve().parent.parent.parent / "projects"


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("name", help="the new project's name (a lowercase identifier)")
    parser.add_argument("--from", dest="source", default="template", metavar="PROJECT",
                        help="the project to copy (default: template)")
    parser.add_argument("--with-sims", action="store_true",
                        help="start from the template wired to the simulated UAV (MAVLink) "
                             f"and UGV (MQTT): the same as --from {WITH_SIMS}")


def source_folder(name: str, root: Path) -> Path:
    """The project to copy: in the projects folder, else MRSS's own (the bundled template)."""
    for base in (root, SOURCE_TREE_PROJECTS):
        try:
            return project_path(name, base)
        except UnknownProjectError:
            continue
    raise UnknownProjectError(name, sorted({*known_projects(root),
                                             *known_projects(SOURCE_TREE_PROJECTS)}))


def rename_project(folder: Path, old: str, new: str) -> list[str]:
    """Rename what carries the old name; the list of what was changed."""
    changed = []
    toml = folder / PROJECT_FILE
    text = toml.read_text(encoding="utf-8")
    pattern = re.compile(r'^(\s*name\s*=\s*)"' + re.escape(old) + r'"', re.MULTILINE)
    text, count = pattern.subn(lambda m: f'{m.group(1)}"{new}"', text, count=1)
    if count:
        toml.write_text(text, encoding="utf-8")
        changed.append(f"{PROJECT_FILE}: name = \"{new}\"")
    procedures = folder / "procedures"
    if procedures.is_dir():
        for path in sorted(procedures.glob(f"*{old}*.py")):
            target = path.with_name(path.name.replace(old, new))
            path.rename(target)
            changed.append(f"procedures/{path.name} -> procedures/{target.name}")
    return changed


def run(args: argparse.Namespace) -> int:
    name: str = args.name
    root = projects_dir()
    if not NAME.match(name):
        print(f"mrss new: {name!r} is not a valid project name: use a lowercase letter, then "
              "lowercase letters, digits or _ (it names a folder, test files and modules)",
              file=sys.stderr)
        return EXIT_REFUSED
    if args.with_sims:
        if args.source not in ("template", WITH_SIMS):
            print(f"mrss new: --with-sims copies {WITH_SIMS}; it cannot be combined with "
                  f"--from {args.source}", file=sys.stderr)
            return EXIT_REFUSED
        args.source = WITH_SIMS
    target = root / name
    if target.exists():
        print(f"mrss new: {target} already exists; choose another name or remove it",
              file=sys.stderr)
        return EXIT_REFUSED
    try:
        source = source_folder(args.source, root)
    except UnknownProjectError as exc:
        print(f"mrss new: cannot copy from {args.source!r}: {exc}", file=sys.stderr)
        return EXIT_REFUSED
    root.mkdir(parents=True, exist_ok=True)
    shutil.copytree(source, target, ignore=IGNORED)
    changed = rename_project(target, source.name, name)
    files = sorted(str(p.relative_to(target)) for p in target.rglob("*") if p.is_file())
    print(f"created {target} from {source}")
    for line in changed:
        print(f"  renamed {line}")
    print(f"  files: {', '.join(files)}")
    print(f"next: adapt the parts marked ADAPT (docs/projects.md), then\n"
          f"  mrss check {name}\n  mrss supervise {name}")
    if name not in known_projects(root):
        print(f"mrss new: {target} has no {PROJECT_FILE}", file=sys.stderr)
        return EXIT_REFUSED
    return 0
