"""`mrss agent FILE.asl [--max-time S]`: run one AgentSpeak agent with a console host.

`.print` lines and environment actions go to stdout; warnings (failed intentions) to
stderr. Exit 0 once the agent is idle, 1 if it is still busy after `--max-time`
seconds, 2 on syntax errors or an unreadable file.
"""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path

from mrss.agentspeak.agent import Agent
from mrss.agentspeak.errors import AslSyntaxError
from mrss.agentspeak.host import ConsoleHost, run_standalone


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("file", help="the AgentSpeak program (.asl)")
    parser.add_argument("--max-time", type=float, default=None, metavar="S",
                        help="give up (exit 1) if the agent is not idle after S seconds")
    parser.add_argument("--name", default=None, help="agent name (default: the file's stem)")


def _line(text: str) -> None:
    sys.stdout.write(text + "\n")
    sys.stdout.flush()


def run(args: argparse.Namespace) -> int:
    logging.basicConfig(level=logging.WARNING, format="%(message)s", stream=sys.stderr)
    path = Path(args.file)
    try:
        source = path.read_text(encoding="utf-8")
    except OSError as exc:
        print(f"mrss agent: cannot read {path}: {exc.strerror or exc}", file=sys.stderr)
        return 2
    host = ConsoleHost(_line)
    try:
        agent = Agent(source, file=str(path), host=host, name=args.name or path.stem, out=_line)
    except AslSyntaxError as exc:
        print(str(exc), file=sys.stderr)
        return 2
    host.agent = agent
    if run_standalone(agent, args.max_time):
        return 0
    print(f"mrss agent: still busy after {args.max_time:g} s", file=sys.stderr)
    return 1
