"""`[map]`: how the dashboard's map draws the project's world-model objects.

The table must read (`mrss.config.map.read_map`: known keys, one-character glyphs, Rich
styles, states with a state_field); a kind that neither the world model's seed nor
anything else in the project names is probably misspelt (a warning).
"""

from __future__ import annotations

import re

from mrss.check.findings import Report
from mrss.check.toml_lines import key_line, read_table
from mrss.config.map import DEFAULT_KINDS, SECTION, MapConfig, read_map
from mrss.config.project import ProjectConfig

PROJECT_FILES = ("*.py", "*.json", "*.asl")


def check_map(config: ProjectConfig, report: Report) -> MapConfig | None:
    """Findings for `[map]`; the table read, or None when it is absent or wrong."""
    styles = read_table(config, report, SECTION, read_map, title="[map]")
    if styles is None:
        return None
    file = str(config.file)
    text = _project_text(config)
    for kind in sorted(set(styles.kinds) | styles.hide):
        if kind in DEFAULT_KINDS or re.search(rf"[\"']{re.escape(kind)}[\"']", text):
            continue
        key = f"{SECTION}.kinds.{kind}" if kind in styles.kinds else f"{SECTION}.hide"
        report.warning(file, f"[map] kind {kind!r}: no file of the project names it "
                       "(a world-model object's \"kind\"): misspelt?",
                       line=key_line(config, key), check="map", key=key)
    report.summary.append(f"  map: styles for {', '.join(sorted(styles.kinds)) or 'none'}"
                          f"; hidden {', '.join(sorted(styles.hide)) or 'none'}")
    return styles


def _project_text(config: ProjectConfig) -> str:
    parts = []
    for pattern in PROJECT_FILES:
        for path in sorted(config.directory.glob(pattern)):
            try:
                parts.append(path.read_text(encoding="utf-8", errors="replace"))
            except OSError:
                continue
    return "\n".join(parts)
