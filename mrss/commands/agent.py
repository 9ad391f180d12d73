"""`mrss agent FILE.asl [--max-time S]`: run one AgentSpeak agent with a console host.

`.print` lines and environment actions go to stdout; warnings (failed intentions) to
stderr. Exit 0 once the agent is idle, 1 if it is still busy after `--max-time`
seconds, 2 on syntax errors or an unreadable file.
"""

from __future__ import annotations

import argparse
import logging
import sys
import time
from pathlib import Path

from mrss.agentspeak.agent import Agent
from mrss.agentspeak.errors import AslSyntaxError
from mrss.agentspeak.host import ConsoleHost


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
    start = time.monotonic()
    while True:
        agent.run_until_idle()
        if agent.is_idle():
            return 0
        waited = time.monotonic() - start
        if args.max_time is not None and waited >= args.max_time:
            print(f"mrss agent: still busy after {args.max_time:g} s", file=sys.stderr)
            return 1
        remaining = 1.0 if args.max_time is None else min(1.0, args.max_time - waited)
        agent.wait_for_work(remaining)
