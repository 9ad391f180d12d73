"""`mrss bench NAME|all [--quick] [--json]`: run one benchmark (or each in turn) and print
its table (`make bench` runs `mrss bench all` at full size). Exits 1 when a target row
of a full-size run is not met (`BenchReport.exit_status`), 2 on a usage error."""

from __future__ import annotations

import argparse
import importlib
import sys

from mrss.bench import BENCHES
from mrss.bench.report import BenchReport


def configure(parser: argparse.ArgumentParser) -> None:
    names = ", ".join(f"{k} ({v})" for k, v in BENCHES.items())
    parser.add_argument("name", help=f"benchmark to run: {names}; or all of them: all")
    parser.add_argument("--quick", action="store_true", help="small sizes, for CI smoke runs")
    parser.add_argument("--json", action="store_true", help="print the result as JSON")
    parser.add_argument("--under-load", action="store_true",
                        help="e2e only: the same rows with two CPU hogs running, beside the "
                             "quiet ones")
    parser.add_argument("--robots", type=int, action="append", metavar="N",
                        help="fleet, allocation: measure this fleet size (repeatable) instead of "
                             "the default sizes")


ALL = "all"


def run(args: argparse.Namespace) -> int:
    if args.name == ALL:
        worst = 0
        for name in BENCHES:
            print(f"== mrss bench {name}", flush=True)
            worst = max(worst, run_one(argparse.Namespace(**{**vars(args), "name": name})))
        return worst
    return run_one(args)


def run_one(args: argparse.Namespace) -> int:
    if args.name not in BENCHES:
        print(f"mrss bench: unknown benchmark {args.name!r}; known: {', '.join(BENCHES)}, {ALL}",
              file=sys.stderr)
        return 2
    try:
        module = importlib.import_module(f"mrss.bench.{args.name}")
    except ModuleNotFoundError as exc:
        if exc.name != f"mrss.bench.{args.name}":
            raise
        print(f"mrss bench {args.name}: not yet available in this version", file=sys.stderr)
        return 2
    if getattr(args, "under_load", False):
        if args.name != "e2e":
            print(f"mrss bench {args.name}: --under-load is for e2e only", file=sys.stderr)
            return 2
        report: BenchReport = module.run(quick=args.quick, under_load=True)
    elif getattr(args, "robots", None):
        if args.name not in ("fleet", "allocation"):
            print(f"mrss bench {args.name}: --robots is for fleet and allocation only",
                  file=sys.stderr)
            return 2
        if min(args.robots) < 2:
            print(f"mrss bench {args.name}: --robots must be at least 2", file=sys.stderr)
            return 2
        report = module.run(quick=args.quick, sizes=args.robots)
    else:
        report = module.run(quick=args.quick)
    print(report.to_json() if args.json else report.to_text())
    status = report.exit_status()
    if status:
        missed = [t.description for t in report.targets if not t.met]
        print(f"mrss bench {args.name}: {len(missed)} target(s) not met: " + "; ".join(missed),
              file=sys.stderr)
    return status
