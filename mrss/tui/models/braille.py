"""A braille canvas: 2x4 dots per terminal cell, glyphs and labels on top.

Drawn into by the map (tracks, area outlines as dots; robots and objects as glyphs);
read out as rows of (text, style) runs. Pure Python: no Textual. Whatever falls outside
the canvas is dropped.
"""

from __future__ import annotations

import math

BRAILLE_BASE = 0x2800
# bit of the dot at (x % 2, y % 4) within its cell
DOT_BITS = ((0x01, 0x02, 0x04, 0x40), (0x08, 0x10, 0x20, 0x80))
MAX_LINE_DOTS = 4000  # a longer segment is mostly off-canvas: drawn in this many steps


class BrailleCanvas:
    """Cells of braille dots, each cell with the style of what drew it last."""

    def __init__(self, width: int, height: int) -> None:
        self.width, self.height = max(0, width), max(0, height)
        self._bits = [[0] * self.width for _ in range(self.height)]
        self._styles = [[""] * self.width for _ in range(self.height)]
        self._glyphs: dict[tuple[int, int], tuple[str, str]] = {}

    def copy(self) -> BrailleCanvas:
        """A canvas with the same dots and glyphs, drawn into apart from this one."""
        other = BrailleCanvas.__new__(BrailleCanvas)
        other.width, other.height = self.width, self.height
        other._bits = [row[:] for row in self._bits]
        other._styles = [row[:] for row in self._styles]
        other._glyphs = dict(self._glyphs)
        return other

    def dot(self, x: float, y: float, style: str = "") -> None:
        """Set the dot at (x, y) in dots (x right, y down)."""
        if not (math.isfinite(x) and math.isfinite(y)):
            return
        xi, yi = math.floor(x), math.floor(y)
        col, row = xi // 2, yi // 4
        if 0 <= col < self.width and 0 <= row < self.height:
            self._bits[row][col] |= DOT_BITS[xi % 2][yi % 4]
            self._styles[row][col] = style

    def line(self, x0: float, y0: float, x1: float, y1: float, style: str = "") -> None:
        """Dots along the segment from (x0, y0) to (x1, y1): only its part on the canvas
        is walked, so a zoomed-in view costs no more than a fitted one."""
        clipped = self._clip(x0, y0, x1, y1)
        if clipped is None:
            return
        x0, y0, x1, y1 = clipped
        steps = min(MAX_LINE_DOTS, max(1, math.ceil(max(abs(x1 - x0), abs(y1 - y0)))))
        dx, dy = (x1 - x0) / steps, (y1 - y0) / steps
        bits, styles, width, height = self._bits, self._styles, self.width, self.height
        for i in range(steps + 1):
            xi, yi = math.floor(x0 + dx * i), math.floor(y0 + dy * i)
            col, row = xi >> 1, yi >> 2
            if 0 <= col < width and 0 <= row < height:
                bits[row][col] |= DOT_BITS[xi & 1][yi & 3]
                styles[row][col] = style

    def _clip(self, x0: float, y0: float, x1: float,
              y1: float) -> tuple[float, float, float, float] | None:
        """The segment cut to the canvas (Liang-Barsky), None if it misses it."""
        if not all(math.isfinite(v) for v in (x0, y0, x1, y1)):
            return None
        t0, t1 = 0.0, 1.0
        dx, dy = x1 - x0, y1 - y0
        for p, q in ((-dx, x0 + 1), (dx, self.width * 2 + 1 - x0),
                     (-dy, y0 + 1), (dy, self.height * 4 + 1 - y0)):
            if p == 0:
                if q < 0:
                    return None
                continue
            t = q / p
            if p < 0:
                t0 = max(t0, t)
            else:
                t1 = min(t1, t)
            if t0 > t1:
                return None
        return x0 + t0 * dx, y0 + t0 * dy, x0 + t1 * dx, y0 + t1 * dy

    def polyline(self, points: list[tuple[float, float]], style: str = "") -> None:
        """Lines through `points` (in dots), in order."""
        for (x0, y0), (x1, y1) in zip(points, points[1:], strict=False):
            self.line(x0, y0, x1, y1, style)

    def fill_polygon(self, points: list[tuple[float, float]], style: str = "") -> None:
        """Every other dot inside the polygon (even-odd rule), so lines over it still show."""
        finite = [(x, y) for x, y in points if math.isfinite(x) and math.isfinite(y)]
        if len(finite) < 3:
            return
        edges = list(zip(finite, finite[1:] + finite[:1], strict=True))
        top = max(0, math.floor(min(y for _, y in finite)))
        bottom = min(self.height * 4 - 1, math.ceil(max(y for _, y in finite)))
        for y in range(top, bottom + 1, 2):
            yc = y + 0.5
            xs = sorted(x0 + (yc - y0) * (x1 - x0) / (y1 - y0)
                        for (x0, y0), (x1, y1) in edges if (y0 <= yc) != (y1 <= yc))
            for left, right in zip(xs[::2], xs[1::2], strict=False):
                start = max(0, math.ceil(left - 0.5))
                start += (start + y // 2) % 2  # a checkerboard of dots
                for x in range(start, min(self.width * 2, math.floor(right + 0.5)), 2):
                    self.dot(x, y, style)

    def glyph(self, col: int, row: int, char: str, style: str = "", *,
              over: bool = True) -> bool:
        """Put one character in a cell (over any dots, and over another character unless
        `over` is false); False if off the canvas or, with `over` false, taken."""
        if not over and (col, row) in self._glyphs:
            return False
        if 0 <= col < self.width and 0 <= row < self.height:
            self._glyphs[(col, row)] = (char, style)
            return True
        return False

    def label(self, col: int, row: int, text: str, style: str = "") -> None:
        """Text from a cell rightwards, over empty cells only (never over a glyph)."""
        for i, char in enumerate(text):
            if (col + i, row) in self._glyphs:
                return
            self.glyph(col + i, row, char, style)

    def rows(self) -> list[list[tuple[str, str]]]:
        """Each row as runs of (text, style)."""
        out: list[list[tuple[str, str]]] = []
        for r in range(self.height):
            runs: list[tuple[str, str]] = []
            for c in range(self.width):
                glyph = self._glyphs.get((c, r))
                if glyph is not None:
                    char, style = glyph
                else:
                    bits = self._bits[r][c]
                    char = chr(BRAILLE_BASE + bits) if bits else " "
                    style = self._styles[r][c] if bits else ""
                if runs and runs[-1][1] == style:
                    runs[-1] = (runs[-1][0] + char, style)
                else:
                    runs.append((char, style))
            out.append(runs)
        return out

    def text(self) -> list[str]:
        """Each row as plain text (tests, captures)."""
        return ["".join(run for run, _ in row) for row in self.rows()]
