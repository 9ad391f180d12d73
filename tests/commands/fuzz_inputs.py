"""Seeded generators of hostile inputs for the fuzz tests of the commands, and the
harness that runs one command in-process and checks it ended cleanly."""

from __future__ import annotations

import contextlib
import io
import math
import random
import signal
import struct
import zlib
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import msgpack

from mrss.cli import INTERNAL, main
from mrss.recording.format import MAGIC

VALID_ASL = """\
count(0).
limit(3).
ready :- count(N) & limit(L) & N < L.
!start.
+!start : ready <- ?count(N); -+count(N + 1); .print(N); !start.
+!start <- .print(done); act(a1, 2.5).
+area(A) [source(percept)] <- .print(area, A); query(level, [A], R); .print(R).
-!start <- .print(failed).
"""

EXTREME_NUMBERS = ["1e400", "-1e400", "9" * 400, "1" * 5000, "nan", "inf", "-inf", "0",
                   "-0", "1e-400", "1e-300", "-1", "1e308", "2e308", "0x10", "", " ",
                   "1_000", "٣"]
NASTY_TEXT = ["", " ", "\t", "(", ")", "[", "]", "\"", "'", "\\", "..", "a(", "a(b", "a(,)",
              "a[", "a[b", "~", "!", "?", "+", "-", "{", "}", "X", "_", "é", "\u2028",
              "a(1e400)", "b(X+1)", "a(" * 300 + ")" * 300, "a(\"\\x\")", "a.b.c(",
              "not a", "a :- b", "+!g <- !g", "\x00", "\x7f", "\ufffd",
              "a\udcff"]  # the last: a non-UTF-8 byte in argv, as Python decodes it


def random_bytes(rng: random.Random, n: int | None = None) -> bytes:
    return bytes(rng.randrange(256) for _ in range(rng.randrange(0, 300) if n is None else n))


def mutate_text(rng: random.Random, text: str) -> str:
    """A few random edits: cut, duplicate, insert nasty text or a number, swap a char."""
    chars = list(text)
    for _ in range(rng.randrange(1, 5)):
        pos = rng.randrange(len(chars) + 1)
        choice = rng.randrange(5)
        if choice == 0 and chars:
            del chars[pos:pos + rng.randrange(1, 10)]
        elif choice == 1:
            chars[pos:pos] = list(rng.choice(NASTY_TEXT))
        elif choice == 2:
            chars[pos:pos] = list(rng.choice(EXTREME_NUMBERS))
        elif choice == 3 and chars:
            chars[min(pos, len(chars) - 1)] = chr(rng.randrange(32, 127))
        else:
            chars[pos:pos] = list(text[rng.randrange(len(text)):][:20])
    return "".join(chars)


def hostile_file(rng: random.Random, valid: str) -> bytes:
    """Random bytes, a mutated valid text, or a valid text with non-UTF-8 bytes in it."""
    kind = rng.randrange(4)
    if kind == 0:
        return random_bytes(rng)
    if kind == 1:
        return mutate_text(rng, valid).encode("utf-8", errors="surrogatepass")
    if kind == 2:
        data = valid.encode()
        pos = rng.randrange(len(data) + 1)
        return data[:pos] + random_bytes(rng, rng.randrange(1, 4)) + b"\xff" + data[pos:]
    return mutate_text(rng, valid).encode("latin-1", errors="replace")


def argument(rng: random.Random) -> str:
    """A command-line word (no NUL: a real argv cannot hold one)."""
    word = rng.choice([*EXTREME_NUMBERS, *NASTY_TEXT, "1", "0.01", "-5", "area(a1)"])
    return word.replace("\x00", "")


# ---------------------------------------------------------------------------- recordings
def block(body: bytes) -> bytes:
    return struct.pack("!II", len(body), zlib.crc32(body)) + body


def recording(rng: random.Random, n: int = 8) -> bytes:
    """A recording with valid checksums whose entries have hostile times and frames."""
    times = [0.0, 1.0, 1e300, 1.7e308, -1.0, -1e300, 1e9, 1e-300, 5.0, 2e9]
    out = MAGIC + block(msgpack.packb({"created": 1.0, "endpoints": {}, "prefixes": [""]}))
    t = 1_700_000_000.0
    for _ in range(n):
        kind = rng.randrange(6)
        if kind == 0:
            t = rng.choice(times)
        elif kind == 1:
            t += rng.choice(times)
        else:
            t += rng.random()
        entry: object = [t if math.isfinite(t) else 0.0,
                         [b"percept", random_bytes(rng, rng.randrange(0, 20))],
                         rng.choice(["", "bad"])]
        if rng.randrange(8) == 0:
            entry = rng.choice([[t], {"t": t}, [float("nan"), [b"x"], ""], "x", [t, [], ""],
                                [t, [1], ""], [t, [b"a"], 3], [2**63, [b"a"], ""]])
        out += block(msgpack.packb(entry, use_bin_type=True))
    if rng.randrange(4) == 0:  # damage: truncate, or flip a byte
        cut = rng.randrange(len(out))
        out = out[:cut] if rng.randrange(2) else out[:cut] + bytes([out[cut] ^ 0xFF]) + out[
            cut + 1:]
    return out


# ------------------------------------------------------------------------------- harness
@dataclass
class Outcome:
    code: int
    out: str
    err: str


@contextlib.contextmanager
def kept_signals() -> Iterator[None]:
    """Restore SIGINT/SIGTERM handlers a command (`mrss record`) installs."""
    saved = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for s, handler in saved.items():
            signal.signal(s, handler)


def run_main(argv: list[str], stdin: str = "") -> Outcome:
    """`mrss ARGV` in this process; its exit code and what it printed."""
    out, err = io.StringIO(), io.StringIO()
    with (kept_signals(), contextlib.redirect_stdout(out), contextlib.redirect_stderr(err),
          _stdin(stdin)):
        try:
            code = main(argv)
        except SystemExit as exc:  # argparse: usage errors
            code = exc.code if isinstance(exc.code, int) else 2
    return Outcome(code, out.getvalue(), err.getvalue())


@contextlib.contextmanager
def _stdin(text: str) -> Iterator[None]:
    import sys

    saved = sys.stdin
    sys.stdin = io.StringIO(text)
    try:
        yield
    finally:
        sys.stdin = saved


def assert_total(outcome: Outcome, argv: list[str]) -> None:
    """The command ended with 0, 1 or 2 and a clear message: no traceback, no crash."""
    where = f"mrss {' '.join(repr(a)[:80] for a in argv)}"
    assert "Traceback (most recent call last)" not in outcome.err, f"{where}\n{outcome.err}"
    assert INTERNAL not in outcome.err, f"{where}\n{outcome.err}"
    assert outcome.code in (0, 1, 2), f"{where}: exit {outcome.code}\n{outcome.err}"
    if outcome.code == 2:
        assert (outcome.err + outcome.out).strip(), f"{where}: exit 2 without a message"


def write(path: Path, data: bytes) -> Path:
    path.write_bytes(data)
    return path
