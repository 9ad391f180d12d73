"""The random numbers of `.random`, `math.random` and `.shuffle`: Java's
`java.util.Random` (a 48-bit linear congruential generator, specified in its javadoc),
which Jason uses, so that after `.set_random_seed(N)` a program draws the numbers it
draws on Jason (`.set_random_seed(20); X = math.random(10)` gives 7.32...).

One generator per process, seeded from the clock until `.set_random_seed`; Jason keeps
one per agent, which is the same for a program run alone."""

from __future__ import annotations

import random
import time

_MULTIPLIER = 0x5DEECE66D
_ADDEND = 0xB
_MASK = (1 << 48) - 1


class JavaRandom(random.Random):
    """java.util.Random: `next_double`, `next_int(bound)`; as a `random.Random` its
    `random()` is `next_double` and its bits come from `next`, so `shuffle` and the
    other methods of the standard library draw from the same sequence."""

    def __init__(self, seed: int | None = None) -> None:
        self._state = 0
        super().__init__(time.time_ns() if seed is None else seed)

    def seed(self, a: object = None, version: int = 2) -> None:
        n = a if isinstance(a, int) else time.time_ns()
        self._state = (n ^ _MULTIPLIER) & _MASK

    def _next(self, bits: int) -> int:
        self._state = (self._state * _MULTIPLIER + _ADDEND) & _MASK
        return self._state >> (48 - bits)

    def random(self) -> float:
        return ((self._next(26) << 27) + self._next(27)) * (1.0 / (1 << 53))

    def getrandbits(self, k: int) -> int:
        out, got = 0, 0
        while got < k:
            take = min(32, k - got)
            out |= self._next(take) << got
            got += take
        return out

    def next_int(self, bound: int) -> int:
        """A number in [0, bound), as Java's nextInt(bound)."""
        r = self._next(31)
        m = bound - 1
        if bound & m == 0:
            return (bound * r) >> 31
        u = r
        while True:
            r = u % bound
            if _int32(u - r + m) >= 0:
                return r
            u = self._next(31)


def _int32(n: int) -> int:
    n &= 0xFFFFFFFF
    return n - (1 << 32) if n >= 1 << 31 else n


RNG = JavaRandom()
