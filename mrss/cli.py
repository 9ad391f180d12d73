"""The `mrss` command: one verb per job, each implemented in `mrss.commands.<verb>`."""

from __future__ import annotations

import argparse
import importlib
import importlib.util
import os
import sys
from collections.abc import Collection, Sequence
from dataclasses import dataclass

from mrss import __version__
from mrss.bench import BENCHES
from mrss.config.projects import project_path
from mrss.errors import UnknownProjectError


@dataclass(frozen=True)
class Verb:
    """A CLI verb: its help line, whether it takes a project, and whether it is built."""

    name: str
    help: str
    takes_project: bool = False
    built: bool = False


VERBS: tuple[Verb, ...] = (
    Verb("supervise", "run a project's whole system under the root supervisor", True),
    Verb("tui", "open the monitoring and debug dashboard", True),
    Verb("users", "manage the operators of a project: add, remove, list, set-role", True),
    Verb("keys", "make a node's CurveZMQ keypair (projects with [nodes])", True),
    Verb("new", "create a project folder from the template"),
    Verb("check", "load and validate a project without starting robots", True),
    Verb("test", "run a project's test procedures", True),
    Verb("agent", "run one AgentSpeak agent standalone with a console host"),
    Verb("send", "publish a message (e.g. a percept) on a running system's bus"),
    Verb("record", "record a running system's bus traffic to a file"),
    Verb("replay", "replay a recorded bus session"),
    Verb("recording", "look into a recording: info, export as csv or jsonl"),
    Verb("incident", "export a run's incident record (md, html, jsonl, csv)"),
    Verb("sim", "run a simulated robot (uav, ugv) or a fleet of them"),
    Verb("chaos", "run a fault campaign and check the mission's invariants", True),
    Verb("bench", f"run a benchmark ({', '.join(BENCHES)})", built=True),
)

NOT_BUILT_EXIT = 2
INTERNAL = "internal error"  # the fuzz tests assert no input reaches this


def _verb_module(name: str) -> str:
    return f"mrss.commands.{name}"


def build_parser(configure: Collection[str] | None = None) -> argparse.ArgumentParser:
    """The argument parser with one sub-parser per verb; only the verbs in `configure`
    (default: all) import their module to declare their arguments -- `main` configures
    just the verb it runs, so `mrss agent` does not import the whole system."""
    parser = argparse.ArgumentParser(
        prog="mrss", description="MRSS: multi-robot support system for disaster response."
    )
    parser.add_argument("--version", action="version", version=f"mrss {__version__}")
    sub = parser.add_subparsers(dest="verb", metavar="VERB")
    for verb in VERBS:
        p = sub.add_parser(verb.name, help=verb.help, description=verb.help)
        if configure is not None and verb.name not in configure:
            p.add_argument("rest", nargs=argparse.REMAINDER, help=argparse.SUPPRESS)
        elif verb.built or _module_exists(verb.name):
            module = importlib.import_module(_verb_module(verb.name))
            module.configure(p)
        else:
            if verb.takes_project:
                p.add_argument("project", nargs="?", help="project name (projects/<name>/)")
            p.add_argument("rest", nargs=argparse.REMAINDER, help=argparse.SUPPRESS)
    return parser


def _not_utf8(word: str) -> int | None:
    """The first byte of `word` that is not UTF-8 (a lone surrogate), or None."""
    try:
        word.encode("utf-8")
    except UnicodeEncodeError as exc:
        char = ord(word[exc.start])
        return char - 0xDC00 if 0xDC80 <= char <= 0xDCFF else char & 0xFF
    return None


def _module_exists(name: str) -> bool:
    return importlib.util.find_spec(_verb_module(name)) is not None


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the `mrss` console script; returns the exit code."""
    words = list(sys.argv[1:] if argv is None else argv)
    for word in words:  # bytes that are not UTF-8 arrive as lone surrogates (PEP 383)
        bad = _not_utf8(word)
        if bad is not None:
            print(f"mrss: argument {word.encode('utf-8', 'surrogateescape')!r} is not UTF-8 "
                  f"text (byte 0x{bad:02x}); arguments must be UTF-8", file=sys.stderr)
            return NOT_BUILT_EXIT
    chosen = next((w for w in words if not w.startswith("-")), None)  # the verb, if any
    parser = build_parser([chosen] if chosen is not None else [])
    args = parser.parse_args(words)
    if args.verb is None:
        parser.print_help()
        return NOT_BUILT_EXIT
    verb = next(v for v in VERBS if v.name == args.verb)
    try:
        if not (verb.built or _module_exists(verb.name)):
            print(f"mrss {verb.name}: not yet available in this version", file=sys.stderr)
            return NOT_BUILT_EXIT
        if verb.takes_project and getattr(args, "project", None) is not None:
            project_path(args.project)
        module = importlib.import_module(_verb_module(verb.name))
        result: int = module.run(args)
        return result
    except UnknownProjectError as exc:
        print(f"mrss {verb.name}: {exc}", file=sys.stderr)
        return NOT_BUILT_EXIT
    except KeyboardInterrupt:
        return 130
    except RecursionError:
        print(f"mrss {verb.name}: {INTERNAL}: input nested too deeply", file=sys.stderr)
        return NOT_BUILT_EXIT
    except Exception as exc:  # last resort: a one-line error, never a traceback
        print(f"mrss {verb.name}: {INTERNAL}: {type(exc).__name__}: {exc} (please report "
              f"it with the input; MRSS_TRACEBACK=1 shows where)", file=sys.stderr)
        if os.environ.get("MRSS_TRACEBACK"):
            raise
        return NOT_BUILT_EXIT
