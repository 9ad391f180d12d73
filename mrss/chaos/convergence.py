"""When is the system converged: the probe rule of the converged invariant (pure).

A probe is converged when `mrss supervise` runs, every component of the supervision tree
is running, the reasoner and the journal answered, every intention that waits on an
action waits on one the journal has open (no stuck latch), and every open action of the
journal is waited on by an intention (no robot working for nobody). The action an
intention waits on is the uuid in its `waiting_on` ("action '<uuid>'").
"""

from __future__ import annotations

import re
from typing import Any

from mrss.chaos.history import History, Probe

UUID_IN_HANDLE = re.compile(r"'([0-9a-f]{32})'")


def probe_problems(p: Probe) -> list[str]:
    """Why the system is not converged at this probe (empty: it is)."""
    if not p.system_running:
        return ["mrss supervise is not running"]
    problems = []
    if p.tree is None:
        problems.append("the supervision tree did not answer")
    else:
        problems += [f"component {c} is {s}" for c, s in _not_running(p.tree)]
    if p.mind is None:
        problems.append("the reasoner did not answer")
    if p.open_actions is None:
        problems.append("the RCL journal could not be read")
    if p.mind is None or p.open_actions is None:
        return problems
    opened = {a.uuid: a for a in p.open_actions}
    waited: set[str] = set()
    for it in p.mind.get("intentions", []):
        found = UUID_IN_HANDLE.search(str(it.get("waiting_on") or ""))
        if found:
            waited.add(found.group(1))
            if found.group(1) not in opened:
                problems.append(f"intention #{it.get('id')} waits on action {found.group(1)}"
                                ", which is not open in the journal")
    problems += [f"action {a.uuid} ({a.robot}, goal {a.goal}, {a.state}, of {a.requester} "
                 f"inc {a.requester_inc}) is open but no intention waits on it"
                 for a in p.open_actions if a.uuid not in waited]
    return problems


def _not_running(tree: dict[str, Any]) -> list[tuple[str, str]]:
    out = []
    for child in tree.get("children", []) or []:
        if child.get("state") != "running":
            out.append((str(child.get("id")), str(child.get("state"))))
        out += _not_running(child)
    return out


def converged_after(h: History) -> float | None:
    """Seconds from the end of the last fault to the first converged probe (None: never)."""
    start = h.faults_ended_at
    for p in h.probes:
        if p.t >= start and not probe_problems(p):
            return p.t - start
    return None
