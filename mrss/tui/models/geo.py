"""Map math for the dashboard's map panel: latitude/longitude to braille dots and back.

A braille cell is 2 dots wide and 4 high; a terminal cell is about twice as high as wide,
so a dot is (about) square and one scale, metres per dot, serves both axes. The
projection is equirectangular around the view's centre (longitudes shrink with the cosine
of the centre's latitude): exact enough for the few kilometres of a mission area.
Pure Python: no Textual.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

METRES_PER_DEGREE = 6_371_000.0 * math.pi / 180.0  # on the mean Earth sphere
DOTS_X, DOTS_Y = 2, 4  # braille dots per terminal cell
MIN_SCALE = 0.05  # metres per dot: closest zoom
MAX_SCALE = 100_000.0  # metres per dot: widest zoom


@dataclass
class Viewport:
    """What the map shows: the centre and the scale (metres per braille dot)."""

    lat: float = 0.0
    lon: float = 0.0
    scale: float = 10.0

    def to_dots(self, lat: float, lon: float, width: int, height: int) -> tuple[float, float]:
        """The dot (x right, y down) of a position on a canvas of width x height cells."""
        east = (lon - self.lon) * METRES_PER_DEGREE * math.cos(math.radians(self.lat))
        north = (lat - self.lat) * METRES_PER_DEGREE
        return (width * DOTS_X / 2 + east / self.scale,
                height * DOTS_Y / 2 - north / self.scale)

    def to_cell(self, lat: float, lon: float, width: int, height: int) -> tuple[int, int]:
        """The terminal cell (column, row) a position falls in (maybe outside the canvas)."""
        x, y = self.to_dots(lat, lon, width, height)
        return math.floor(x / DOTS_X), math.floor(y / DOTS_Y)

    def to_latlon(self, x: float, y: float, width: int, height: int) -> tuple[float, float]:
        """The position at dot (x, y): the inverse of `to_dots`."""
        east = (x - width * DOTS_X / 2) * self.scale
        north = (height * DOTS_Y / 2 - y) * self.scale
        lat = self.lat + north / METRES_PER_DEGREE
        lon = self.lon + east / (METRES_PER_DEGREE * math.cos(math.radians(self.lat)))
        return lat, lon

    def zoom(self, factor: float) -> None:
        """Zoom in (factor > 1) or out (< 1), keeping the centre."""
        self.scale = min(MAX_SCALE, max(MIN_SCALE, self.scale / factor))

    def pan(self, right: float, down: float, width: int, height: int) -> None:
        """Move the view by a fraction of its width (right) and height (down)."""
        lat, lon = self.to_latlon(width * DOTS_X * (0.5 + right),
                                  height * DOTS_Y * (0.5 + down), width, height)
        self.lat, self.lon = lat, lon

    def centre_on(self, lat: float, lon: float) -> None:
        self.lat, self.lon = lat, lon

    def fit(self, points: Iterable[tuple[float, float]], width: int, height: int,
            margin: float = 0.1) -> bool:
        """Centre and scale so every (lat, lon) shows, with a margin; False if none."""
        pts = list(points)
        if not pts or width < 1 or height < 1:
            return False
        lats, lons = [p[0] for p in pts], [p[1] for p in pts]
        self.lat, self.lon = (min(lats) + max(lats)) / 2, (min(lons) + max(lons)) / 2
        north = (max(lats) - min(lats)) * METRES_PER_DEGREE
        east = ((max(lons) - min(lons)) * METRES_PER_DEGREE
                * math.cos(math.radians(self.lat)))
        usable = 1.0 - 2 * margin
        needed = max(north / (height * DOTS_Y * usable), east / (width * DOTS_X * usable))
        self.scale = min(MAX_SCALE, max(needed, 1.0))
        return True

    def describe(self, width: int) -> str:
        """The width the view spans, for the panel's title: `1.2 km wide`."""
        metres = self.scale * width * DOTS_X
        return f"{metres / 1000:.1f} km wide" if metres >= 1000 else f"{metres:.0f} m wide"


ARROWS = "↑↗→↘↓↙←↖"


def heading_arrow(heading: float | None) -> str:
    """An arrow for a heading in degrees (0 north, 90 east); `●` when unknown."""
    if heading is None or not math.isfinite(heading):
        return "●"
    return ARROWS[round((heading % 360) / 45) % 8]
