"""`[[alerts]]`: a project's own alert rules for the dashboard (`mrss.config.alerts`).

The array must read (known keys, a name and a field, a threshold, a known severity;
names differ); an error names `alerts[N].key` and the line of that rule's key. A rule
for a robot no RCL declares (`[components.<rcl>.robots.<id>]`) is probably misspelt:
a warning, with the robot it may have meant.
"""

from __future__ import annotations

import re
from collections.abc import Mapping

from mrss.check.findings import Report, did_you_mean
from mrss.check.toml_lines import read_table
from mrss.config.alerts import SECTION, read_alert_rules
from mrss.config.project import ProjectConfig

_INDEXED = re.compile(rf"^{SECTION}\[(\d+)\](?:\.(\w+))?$")


def check_alerts(config: ProjectConfig, report: Report) -> None:
    """Findings for `[[alerts]]`; nothing when it is absent."""
    rules = read_table(config, report, SECTION, read_alert_rules, title="[[alerts]]",
                       line=rule_line)
    if rules is None:
        return
    file = str(config.file)
    robots = declared_robots(config)
    for index, rule in enumerate(rules, start=1):
        if rule.robot and robots and rule.robot not in robots:
            key = f"{SECTION}[{index}].robot"
            report.warning(file, f"[[alerts]] {rule.name!r}: no RCL declares robot "
                           f"{rule.robot!r}" + did_you_mean(rule.robot, robots,
                                                             what="robots"),
                           line=rule_line(config, key), check="alerts", key=key)
    names = ", ".join(rule.name for rule in rules) or "none"
    report.summary.append(f"  alerts: {len(rules)} rule{'s' if len(rules) != 1 else ''} "
                          f"({names})")


def declared_robots(config: ProjectConfig) -> list[str]:
    """The robot ids of every component's `robots` table (the RCLs')."""
    ids: list[str] = []
    for comp in config.components:
        robots = comp.options.get("robots")
        if isinstance(robots, Mapping):
            ids.extend(str(robot) for robot in robots)
    return ids


def rule_line(config: ProjectConfig, key: str) -> int:
    """The line of `alerts[N].key` (or of the N-th `[[alerts]]` header); 0 if unknown."""
    match = _INDEXED.match(key)
    try:
        lines = config.file.read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError):
        return 0
    headers = [n for n, line in enumerate(lines, start=1)
               if re.match(rf"^\s*\[\[\s*{SECTION}\s*\]\]", line)]
    if match is None:
        return headers[0] if headers else next(
            (n for n, line in enumerate(lines, start=1)
             if re.match(rf"^\s*{SECTION}\s*=", line)), 0)
    index, name = int(match.group(1)), match.group(2)
    if not 0 < index <= len(headers):
        return 0
    start = headers[index - 1]
    if name is None:
        return start
    assign = re.compile(rf"^\s*{re.escape(name)}\s*=")
    for number in range(start + 1, len(lines) + 1):
        line = lines[number - 1]
        if line.lstrip().startswith("["):
            break
        if assign.match(line):
            return number
    return start
