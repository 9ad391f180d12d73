"""The options of the RCL component (`[components.rcl]`), declared once: `mrss check`
judges a table by them, the service reads through them, and the core's defaults are theirs."""

from __future__ import annotations

from typing import Any

from mrss.actors.rcl.allocation.evaluators import DEFAULT, Evaluator
from mrss.options import Check, Option

RCL_OPTIONS: tuple[Option, ...] = (
        Option("layer", str, "rcl.py", "\"file.py\" or \"file.py:Class\" of the RobotCommLayer"),
        Option("robots", dict, {}, "robot id -> its table (link options and the layer's own)"),
        Option("journal", str, None,
               "action journal path (default <run_dir>/<name>-journal.sqlite3)"),
        Option("durable", bool, False, "fsync every journal transition"),
        Option("max_robot_restarts", int, 5, "robot actor restarts before quarantine",
               Check.POSITIVE),
        Option("restart_period", float, 60.0, "... within this many seconds", Check.POSITIVE),
        Option("probation", float, 30.0, "seconds a quarantined robot waits", Check.NON_NEGATIVE),
        Option("adopt_grace", float, 10.0, "seconds a dead requester's actions wait",
               Check.NON_NEGATIVE),
        Option("adopt_grace_suspended", float, 120.0, "the same for suspended actions",
               Check.NON_NEGATIVE),
        Option("preempted_timeout", float, 0.0,
               "seconds a pre-empted action may wait for its resource before it fails "
               "with error(preempted) (0: it waits for ever)", Check.NON_NEGATIVE),
        Option("heartbeat", float, 0.5, "seconds between heartbeats", Check.POSITIVE),
        Option("progress_every", float, 1.0,
               "at most one progress status (repeat) per action every this many seconds "
               "(0: progress goes out with transitions only)", Check.NON_NEGATIVE),
        Option("journal_keep_seconds", float, 86400.0,
               "ended actions older than this are compacted out of the journal",
               Check.NON_NEGATIVE),
        Option("journal_keep_last", int, 1000,
               "... except the newest this many (the dashboard's history)", Check.NON_NEGATIVE),
        Option("journal_compact_period", float, 600.0,
               "seconds between journal compactions (also done at start)", Check.POSITIVE),
        Option("evaluator", str, DEFAULT.value,
               "how bids for a task addressed to a role are ranked (docs/rcl.md, "
               "\"Allocation\")", choices=tuple(e.value for e in Evaluator)),
        Option("bid_timeout", float, 1.0,
               "no longer used: an award asks no robot actor to confirm its bid (accepted, "
               "with a warning, so a project that sets it still starts)",
               Check.POSITIVE),
    )
_BY_NAME = {o.name: o for o in RCL_OPTIONS}


def default(name: str) -> Any:
    """The declared default of one RCL option."""
    return _BY_NAME[name].default
