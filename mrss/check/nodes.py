"""`[nodes]` and every `node = "..."`: the node layout's problems as findings at their
line and column (mrss.config.nodes validates), and the nodes' key files (mrss.bus.curve)."""

from __future__ import annotations

from mrss.bus.curve import paths, permission_problem
from mrss.check.findings import Report
from mrss.check.toml_lines import key_line
from mrss.config.nodes import keys_dir, read_nodes
from mrss.config.project import ProjectConfig


def check_nodes(config: ProjectConfig, report: Report) -> None:
    plan, problems = read_nodes(config)
    for problem in problems:
        line = key_line(config, problem.key)
        report.error(str(config.file), problem.message, line=line,
                     col=_column(config, problem.key, line), check="nodes", key=problem.key)
    if not plan.multi or problems:
        return
    folder = keys_dir(config)
    for name in plan.nodes:
        public, secret = paths(folder, name)
        if not public.is_file():
            report.warning(str(config.file), f"node {name} has no public key {public} "
                           f"(`mrss keys {config.name} --node {name}` on that node, then "
                           "copy its .public file to the others)", line=key_line(
                               config, f"nodes.{name}"), check="nodes", key=f"nodes.{name}")
        for path, is_secret in ((public, False), (secret, True)):
            exposed = permission_problem(path, secret=is_secret) if path.is_file() else ""
            if exposed:
                report.error(str(config.file), exposed, line=key_line(config, f"nodes.{name}"),
                             check="nodes", key=f"nodes.{name}")
    shares = [f"{n} ({len(plan.components_on(n))} components)" for n in plan.nodes]
    report.summary.append(f"nodes: {', '.join(shares)}")


def _column(config: ProjectConfig, key: str, line: int) -> int:
    """1-based column of the key's last part on its line (0 when not found)."""
    if not line:
        return 0
    try:
        text = config.file.read_text(encoding="utf-8").splitlines()[line - 1]
    except (OSError, IndexError, UnicodeDecodeError):
        return 0
    return text.find(key.rsplit(".", 1)[-1]) + 1
