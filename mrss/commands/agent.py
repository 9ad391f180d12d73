"""`mrss agent FILE.asl`: run one AgentSpeak agent without the system.

    mrss agent FILE.asl [--max-time S] [--name NAME] [--percept LIT ...] [--answer F=TERM ...]
    mrss agent FILE.asl --stdin < script.txt     # percepts and outcomes, one per line

`.print` lines and environment actions go to stdout; warnings (failed intentions) to
stderr. Without `--stdin` every action succeeds at once (`action: LIT`) and a
`query(F, Args, R)` is answered from `--answer F=TERM` (else it fails). With `--stdin`
actions stay open (`action N: LIT`) until the script ends them; the line protocol is
mrss.commands.agent_script (docs/agentspeak.md, "Running an agent").

Exit 0 once the agent is idle (with `--stdin`: at the end of the script, with no action
left open), 1 if it is still busy after `--max-time` seconds or actions are left open,
2 on syntax errors, an unreadable file, a bad `--percept`/`--answer`, or a rejected
script line (the rest of the script still runs). `--max-time` bounds reasoning as well
as waiting: the cycles are checked against it every CYCLE_CHUNK cycles, and an alarm
(`time_limit`) interrupts a single step that never ends. With `--stdin` it applies to
the reasoning after each line and to the timers run out at the end.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import logging
import signal
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from types import FrameType

from mrss.agentspeak.agent import Agent, read_program
from mrss.agentspeak.errors import AslSyntaxError
from mrss.agentspeak.host import run_standalone, run_until_idle_by
from mrss.agentspeak.parser import parse_literal
from mrss.agentspeak.scripted import ScriptedHost
from mrss.commands.agent_script import AgentScript, ScriptLineError, StillBusy, parse_value
from mrss.logs import StderrHandler

EXIT_BUSY, EXIT_BAD = 1, 2
MAX_TIME = 1e6  # seconds (about 11.6 days): longer overflows the OS's timers
ALARM_GRACE = 0.05  # seconds: the checks between cycles normally stop it first


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("file", nargs="+",
                        help="the AgentSpeak program (.asl); several run together as a "
                             "society of agents named by their file stems")
    parser.add_argument("--max-time", type=float, default=None, metavar="S",
                        help="give up (exit 1) if the agent is not idle after S seconds")
    parser.add_argument("--name", default=None, help="agent name (default: the file's stem)")
    parser.add_argument("--percept", action="append", default=[], metavar="LIT",
                        help="perceive LIT before reasoning (repeatable)")
    parser.add_argument("--answer", action="append", default=[], metavar="F=TERM",
                        help="answer every query(F, Args, R) with R = TERM (repeatable)")
    parser.add_argument("--stdin", action="store_true",
                        help="read percepts and action outcomes from stdin, one per line; "
                             "actions stay open until a line ends them")


class TimeUp(BaseException):
    """`--max-time` ran out inside one long reasoning step (e.g. a `.findall` over a
    huge `.range`); a BaseException, so no `except Exception` in the interpreter takes it."""


@contextlib.contextmanager
def time_limit(seconds: float | None) -> Iterator[None]:
    """Raise TimeUp in this (main) thread once `seconds` pass: the backstop behind the
    checks between reasoning cycles, for a single step that never ends."""
    usable = (seconds is not None and threading.current_thread() is threading.main_thread()
              and hasattr(signal, "setitimer"))
    delay = 0.0 if seconds is None else max(seconds, 1e-3) + ALARM_GRACE
    outer, interval = signal.getitimer(signal.ITIMER_REAL) if usable else (0.0, 0.0)
    if not usable or 0 < outer <= delay:  # someone else's alarm (a test's timeout) is first
        yield
        return

    def expire(signum: int, frame: FrameType | None) -> None:
        raise TimeUp

    previous = signal.signal(signal.SIGALRM, expire)
    started = time.monotonic()
    signal.setitimer(signal.ITIMER_REAL, delay)
    try:
        yield
    finally:
        try:
            signal.setitimer(signal.ITIMER_REAL, 0)
        finally:  # even if the alarm fired just now
            signal.signal(signal.SIGALRM, previous)
            if outer > 0:  # give the outer alarm back what is left of it
                left = outer - (time.monotonic() - started)
                signal.setitimer(signal.ITIMER_REAL, max(left, 1e-3), interval)


def _line(text: str) -> None:
    sys.stdout.write(text + "\n")
    sys.stdout.flush()


def _answers(pairs: list[str]) -> dict[str, str]:
    answers: dict[str, str] = {}
    for pair in pairs:
        function, sep, term = pair.partition("=")
        if not sep or not function.strip():
            raise ValueError(f"--answer {pair!r}: expected FUNCTION=TERM")
        answers[function.strip()] = parse_value(term)
    return answers


def run(args: argparse.Namespace) -> int:
    console = StderrHandler()  # the stderr of the moment (a test's capture closes)
    console.setFormatter(logging.Formatter("%(message)s"))
    logging.basicConfig(level=logging.WARNING, handlers=[console])
    if args.max_time is not None and not 0 <= args.max_time <= MAX_TIME:
        print(f"mrss agent: --max-time {args.max_time:g}: expected seconds from 0 to "
              f"{MAX_TIME:g}", file=sys.stderr)
        return EXIT_BAD
    if len(args.file) > 1:
        return _run_society(args)
    path = Path(args.file[0])
    try:
        source = read_program(path)
    except OSError as exc:
        print(f"mrss agent: cannot read {path}: {exc.strerror or exc}", file=sys.stderr)
        return EXIT_BAD
    except AslSyntaxError as exc:  # not UTF-8
        print(str(exc), file=sys.stderr)
        return EXIT_BAD
    try:
        answers = _answers(args.answer)
        for lit in args.percept:
            parse_literal(lit)
    except (ValueError, AslSyntaxError) as exc:  # ScriptLineError is a ValueError
        print(f"mrss agent: {exc}", file=sys.stderr)
        return EXIT_BAD
    numbered = bool(args.stdin)
    host = ScriptedHost(
        hold=numbered, on_cancel=lambda n, text: _line(f"cancel {n}: {text}"),
        on_action=lambda n, text: _line(f"action {n}: {text}" if numbered else f"action: {text}"))
    try:
        agent = Agent(source, file=str(path), host=host, name=args.name or path.stem, out=_line)
    except AslSyntaxError as exc:
        print(str(exc), file=sys.stderr)
        return EXIT_BAD
    host.agent = agent
    for function, term in answers.items():
        host.answer_terms[function] = term
    for lit in args.percept:
        agent.add_percept(lit)
    if not args.stdin:
        try:
            with time_limit(args.max_time):
                idle = run_standalone(agent, args.max_time)
        except TimeUp:
            idle = False
        if idle:
            return 0
        print(f"mrss agent: still busy after {args.max_time:g} s", file=sys.stderr)
        return EXIT_BUSY
    return _run_script(agent, host, args.max_time)


def _run_society(args: argparse.Namespace) -> int:
    """Several files: one agent each, named by the file stem, in round-robin."""
    from mrss.agentspeak.society import Society

    for option, given in (("--stdin", args.stdin), ("--name", args.name),
                          ("--percept", args.percept), ("--answer", args.answer)):
        if given:
            print(f"mrss agent: {option} takes one agent file, not {len(args.file)}",
                  file=sys.stderr)
            return EXIT_BAD
    society = Society(out=_line)
    for file in args.file:
        path = Path(file)
        if path.stem in society.agents:
            print(f"mrss agent: two agents named {path.stem} ({file})", file=sys.stderr)
            return EXIT_BAD
        try:
            society.add(path, read_program(path), path.stem)
        except OSError as exc:
            print(f"mrss agent: cannot read {path}: {exc.strerror or exc}", file=sys.stderr)
            return EXIT_BAD
        except AslSyntaxError as exc:
            print(str(exc), file=sys.stderr)
            return EXIT_BAD
    try:
        with time_limit(args.max_time):
            idle = society.run(args.max_time)
    except TimeUp:
        idle = False
    if idle:
        return 0
    print(f"mrss agent: still busy after {args.max_time:g} s", file=sys.stderr)
    return EXIT_BUSY


def _run_script(agent: Agent, host: ScriptedHost, max_time: float | None) -> int:
    script = AgentScript(agent, host, _line, max_time)
    rejected = 0
    try:
        with time_limit(max_time):
            script.apply("")  # the initial goals
        if isinstance(sys.stdin, io.TextIOWrapper):  # bad bytes become U+DC80..U+DCFF
            sys.stdin.reconfigure(errors="surrogateescape")
        for number, line in enumerate(sys.stdin, start=1):
            try:
                _utf8(line)
                with time_limit(max_time):
                    script.apply(line)
            except ScriptLineError as exc:
                rejected += 1
                print(f"stdin:{number}: {exc}", file=sys.stderr)
    except (StillBusy, TimeUp):
        assert max_time is not None
        print(f"mrss agent: still busy after {max_time:g} s of reasoning", file=sys.stderr)
        return EXIT_BUSY
    if not _run_timers_out(agent, max_time):
        print(f"mrss agent: still busy after {max_time:g} s", file=sys.stderr)
        return EXIT_BUSY
    if rejected:
        return EXIT_BAD
    if host.open:
        for handle, text in host.open.items():
            print(f"mrss agent: action {handle} still open: {text}", file=sys.stderr)
        return EXIT_BUSY
    return 0


def _utf8(line: str) -> None:
    """ScriptLineError naming the first byte of `line` that was not UTF-8."""
    try:
        line.encode("utf-8")
    except UnicodeEncodeError as exc:
        char = ord(line[exc.start])
        byte = char - 0xDC00 if 0xDC80 <= char <= 0xDCFF else char
        raise ScriptLineError(f"not UTF-8 text: byte 0x{byte:02x} at column {exc.start + 1}"
                              ) from None


def _run_timers_out(agent: Agent, max_time: float | None) -> bool:
    """Reason until no timer is left (True), or False once `max_time` seconds pass."""
    start = time.monotonic()
    deadline = None if max_time is None else start + max_time
    try:
        with time_limit(max_time):
            while agent.next_deadline() is not None or agent.has_work():
                waited = time.monotonic() - start
                if max_time is not None and waited >= max_time:
                    return False
                agent.wait_for_work(1.0 if max_time is None else min(1.0, max_time - waited))
                run_until_idle_by(agent, deadline)
    except TimeUp:
        return False
    return True
