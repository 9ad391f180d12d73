"""The incident record as a report to hand over (Markdown, HTML) or rows for tools
(JSON lines, CSV): `mrss incident export`."""

from __future__ import annotations

import csv
import html
import io
import json
import time
from collections import Counter
from collections.abc import Callable, Sequence
from enum import StrEnum

from mrss.incident.entries import FIELDS, Entry, IncidentFileError


class ExportFormat(StrEnum):
    MD = "md"
    HTML = "html"
    JSONL = "jsonl"
    CSV = "csv"


def stamp(ts: float) -> str:
    """A row's time, in UTC, to the second."""
    return time.strftime("%Y-%m-%d %H:%M:%S", time.gmtime(ts))


def _summary(entries: Sequence[Entry]) -> list[str]:
    if not entries:
        return ["No rows recorded."]
    kinds = Counter(e.kind.value for e in entries)
    levels = Counter(e.level.value for e in entries)
    return [f"{len(entries)} rows from {stamp(entries[0].ts)} to {stamp(entries[-1].ts)} UTC",
            "by kind: " + ", ".join(f"{k} {n}" for k, n in sorted(kinds.items())),
            "by level: " + ", ".join(f"{k} {n}" for k, n in sorted(levels.items()))]


def _md_cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def to_markdown(title: str, entries: Sequence[Entry],
                problems: Sequence[IncidentFileError] = ()) -> str:
    out = [f"# Incident record: {title}", ""]
    out += [f"- {line}" for line in _summary(entries)]
    if problems:
        out += ["", "## Damaged lines (left out)", ""]
        out += [f"- line {p.line} (byte {p.offset}): {_md_cell(p.why)}" for p in problems]
    out += ["", "## Timeline (UTC)", "", "| # | time | kind | level | who | what |",
            "|---|---|---|---|---|---|"]
    out += [f"| {e.seq} | {stamp(e.ts)} | {e.kind.value} | {e.level.value} | "
            f"{_md_cell(e.who)} | {_md_cell(e.text)} |" for e in entries]
    return "\n".join(out) + "\n"


def to_html(title: str, entries: Sequence[Entry],
            problems: Sequence[IncidentFileError] = ()) -> str:
    esc = html.escape
    out = ["<!DOCTYPE html>", "<html><head><meta charset=\"utf-8\">",
           f"<title>Incident record: {esc(title)}</title>",
           "<style>body{font-family:sans-serif}table{border-collapse:collapse}"
           "td,th{border:1px solid #999;padding:2px 6px}.warning{background:#fff3c4}"
           ".alert{background:#ffd0d0}</style></head><body>",
           f"<h1>Incident record: {esc(title)}</h1><ul>"]
    out += [f"<li>{esc(line)}</li>" for line in _summary(entries)]
    out.append("</ul>")
    if problems:
        out.append("<h2>Damaged lines (left out)</h2><ul>")
        out += [f"<li>line {p.line} (byte {p.offset}): {esc(p.why)}</li>" for p in problems]
        out.append("</ul>")
    out.append("<h2>Timeline (UTC)</h2><table><tr><th>#</th><th>time</th><th>kind</th>"
               "<th>level</th><th>who</th><th>what</th></tr>")
    out += [f"<tr class=\"{e.level.value}\"><td>{e.seq}</td><td>{stamp(e.ts)}</td>"
            f"<td>{e.kind.value}</td><td>{e.level.value}</td><td>{esc(e.who)}</td>"
            f"<td>{esc(e.text)}</td></tr>" for e in entries]
    out.append("</table></body></html>")
    return "\n".join(out) + "\n"


def to_jsonl(title: str, entries: Sequence[Entry],
             problems: Sequence[IncidentFileError] = ()) -> str:
    return "".join(e.to_json() + "\n" for e in entries)


def to_csv(title: str, entries: Sequence[Entry],
           problems: Sequence[IncidentFileError] = ()) -> str:
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(FIELDS)
    for e in entries:
        writer.writerow([e.seq, f"{e.ts:.3f}", e.kind.value, e.level.value, e.source, e.who,
                         e.subject, e.text, json.dumps(e.detail, sort_keys=True, default=str)])
    return buffer.getvalue()


Render = Callable[[str, Sequence[Entry], Sequence[IncidentFileError]], str]
RENDERERS: dict[ExportFormat, Render] = {
    ExportFormat.MD: to_markdown, ExportFormat.HTML: to_html,
    ExportFormat.JSONL: to_jsonl, ExportFormat.CSV: to_csv,
}


def render(fmt: ExportFormat, title: str, entries: Sequence[Entry],
           problems: Sequence[IncidentFileError] = ()) -> str:
    return RENDERERS[fmt](title, entries, problems)
