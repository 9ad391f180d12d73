"""`mrss chaos PROJECT [options]`: a fault campaign against the real system, then its check.

    mrss chaos wildfire --faults 100 --seed 7       # run, record, check, report
    mrss chaos --check RUN_DIR/chaos-history.jsonl  # check a recorded history again

The campaign runs `mrss supervise PROJECT` as its own process, injects the seeded
faults while the project's operator traffic runs, records the history into the run
folder (`chaos-history.jsonl`), checks the invariants over it and prints the report
(docs/chaos.md). Exit code (`mrss.chaos.verdict.Outcome`): 0 the history is complete and
every invariant holds (or has nothing to check), 1 a violation, or every invariant had
nothing to check; 4 the history is incomplete (no journal, no end record, a planned fault
not injected, no operator goal accepted, the log unread) or an invariant could not be
judged; 2 bad usage or a history/project that cannot be read; 3 the system could not be
run.
"""

from __future__ import annotations

import argparse
import json
import random
import sys
import tempfile
from pathlib import Path

from mrss.chaos import history as chaos_history
from mrss.chaos import report, runner
from mrss.chaos.campaign import CampaignError, parse_kinds, parse_range
from mrss.chaos.checker import Bounds, check
from mrss.chaos.verdict import Outcome
from mrss.errors import ConfigError, MrssError

EXIT_OK, EXIT_VIOLATED, EXIT_USAGE, EXIT_NOT_RUN, EXIT_INCOMPLETE = (
    Outcome.HOLDS.exit_code, Outcome.FAILS.exit_code, 2, 3, Outcome.INCOMPLETE.exit_code)


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("project", nargs="?", help="project name (projects/<name>/)")
    parser.add_argument("--faults", type=int, default=10, metavar="N",
                        help="number of faults to inject (default 10)")
    parser.add_argument("--seed", type=int, default=None, metavar="S",
                        help="seed of the fault plan and the operator traffic (default: "
                             "random, printed)")
    parser.add_argument("--interval", default="3..6", metavar="A..B",
                        help="seconds between two faults (default 3..6)")
    parser.add_argument("--duration", default="2..8", metavar="A..B",
                        help="seconds a hang, blackout, link loss, full disk or network "
                             "fault lasts (default 2..8)")
    parser.add_argument("--kinds", default="all", metavar="K,K",
                        help="fault kinds: kill, hang, blackout, broker, link, forkserver, "
                             "disk_full, delay, loss, reorder, partition, robot_loss, "
                             "node_partition, node_loss, node_delay (default all: every kind "
                             "but robot_loss, which is drawn only when named; those without "
                             "a target here are skipped and reported; one named here is "
                             "refused)")
    parser.add_argument("--targets", default="", metavar="C,C",
                        help="components that kill and hang may hit (default: all)")
    parser.add_argument("--operator-every", type=float, default=20.0, metavar="S",
                        help="mean seconds between two operator steps (default 20)")
    parser.add_argument("--warmup", type=float, default=5.0, metavar="S",
                        help="seconds the system runs before the first fault (default 5)")
    parser.add_argument("--latch-bound", type=float, default=Bounds.latch, metavar="S",
                        help="a latch is released within S s of the terminal commit")
    parser.add_argument("--cancel-bound", type=float, default=Bounds.cancel, metavar="S",
                        help="a cancelled or orphaned action ends within S s")
    parser.add_argument("--converge-bound", type=float, default=Bounds.converge,
                        metavar="S", help="the system converges within S s of the last fault")
    parser.add_argument("--award-bound", type=float, default=Bounds.award, metavar="S",
                        help="a task addressed to a role that a capable robot can take is "
                             "awarded within S s (default: derived from the project: link "
                             "loss + allocation + margin, docs/chaos.md)")
    parser.add_argument("--run-dir", type=Path, default=None,
                        help="run folder (default: a new /tmp/mrss-chaos-PROJECT-*)")
    parser.add_argument("--check", type=Path, default=None, metavar="FILE",
                        help="check a recorded history file instead of running a campaign")
    parser.add_argument("--json", action="store_true", help="print the report as JSON")


def run(args: argparse.Namespace) -> int:
    bounds = Bounds(latch=args.latch_bound, cancel=args.cancel_bound,
                    converge=args.converge_bound, award=args.award_bound)
    if args.check is not None:
        return _check(args.check, bounds, args.json)
    if args.project is None:
        print("mrss chaos: give a PROJECT to run a campaign, or --check FILE",
              file=sys.stderr)
        return EXIT_USAGE
    try:
        options = _options(args, bounds)
    except (CampaignError, ConfigError) as exc:
        print(f"mrss chaos: {exc}", file=sys.stderr)
        return EXIT_USAGE
    say = (lambda line: print(line, file=sys.stderr)) if args.json else print
    try:
        path = runner.run(options, say=say)
    except (CampaignError, ConfigError) as exc:
        print(f"mrss chaos: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except (MrssError, AssertionError, OSError) as exc:
        print(f"mrss chaos: the campaign could not run: {exc}", file=sys.stderr)
        return EXIT_NOT_RUN
    return _check(path, bounds, args.json)


def _options(args: argparse.Namespace, bounds: Bounds) -> runner.Options:
    if args.faults < 0:
        raise CampaignError("--faults: must be >= 0")
    if args.warmup < 0:
        raise CampaignError("--warmup: must be >= 0")
    for name in ("operator_every", "latch_bound", "cancel_bound", "converge_bound"):
        if getattr(args, name) <= 0:
            raise CampaignError(f"--{name.replace('_', '-')}: must be > 0")
    if args.award_bound < 0:
        raise CampaignError("--award-bound: must be >= 0 (0: derived from the project)")
    seed = args.seed if args.seed is not None else random.SystemRandom().randrange(1 << 31)
    run_dir = args.run_dir or Path(tempfile.mkdtemp(prefix=f"mrss-chaos-{args.project}-"))
    return runner.Options(
        project=args.project, run_dir=run_dir.resolve(), faults=args.faults, seed=seed,
        kinds=tuple(parse_kinds(args.kinds)), interval=parse_range(args.interval, "--interval"),
        duration=parse_range(args.duration, "--duration"),
        only=tuple(t.strip() for t in args.targets.split(",") if t.strip()),
        operator_every=args.operator_every, warmup=args.warmup, bounds=bounds)


def _check(path: Path, bounds: Bounds, as_json: bool) -> int:
    try:
        history = chaos_history.load(path)
    except chaos_history.HistoryError as exc:
        print(f"mrss chaos: {exc}", file=sys.stderr)
        return EXIT_USAGE
    verdict = check(history, bounds)
    s = report.summary(history, verdict, str(path))
    print(json.dumps(s, indent=2) if as_json else report.text(s))
    return verdict.outcome.exit_code
