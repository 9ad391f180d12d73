"""Terrain grids of the AMADEE-24 site: elevations the slope rule reads.

A terrain grid is a world model object of kind `terrain`: its `geometry` is a
rectangle (a Polygon whose outline is the grid's lon/lat bounding box) and its
attribute `elevation_m` a list of rows of elevations in metres, at evenly spaced
nodes that span the rectangle: the first row is its southern edge, the last its
northern edge; in each row the first value is the western edge, the last the eastern
one. At least 2 x 2 nodes; every row has the same length.

    {"id": "crater_rim", "kind": "terrain",
     "geometry": {"type": "Polygon", "coordinates": [[[44.802, 39.769], [44.804, 39.769],
                  [44.804, 39.771], [44.802, 39.771], [44.802, 39.769]]]},
     "attributes": {"elevation_m": [[0, 1, 2], [0, 1, 3], [0, 2, 9]]}}

`TerrainGrid.of(obj)` validates one (ValueError naming the object), `steepest(a, b)`
walks a straight segment across it and returns the steepest stretch: elevations are
bilinear between nodes, sampled at most half a node spacing apart.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from mrss.api import distance_m

MAX_NODES = 250_000


@dataclass(frozen=True)
class Stretch:
    """The steepest stretch of a segment on a grid: its slope and its two ends."""

    slope_deg: float
    start: tuple[float, float]     # (lat, lon)
    end: tuple[float, float]

    def geometry(self) -> dict[str, Any]:
        return {"type": "LineString", "coordinates": [[self.start[1], self.start[0]],
                                                      [self.end[1], self.end[0]]]}


@dataclass(frozen=True)
class TerrainGrid:
    """Elevations at rows x cols nodes spanning [west, east] x [south, north]."""

    id: str
    west: float
    south: float
    east: float
    north: float
    rows: tuple[tuple[float, ...], ...]

    @classmethod
    def of(cls, obj: dict[str, Any]) -> TerrainGrid:
        """The grid of a world model object; ValueError naming the object when malformed."""
        name = obj.get("id", "?")
        geometry = obj.get("geometry") or {}
        if geometry.get("type") != "Polygon":
            raise ValueError(f"terrain {name!r} needs a Polygon geometry (its rectangle)")
        ring = geometry["coordinates"][0]
        lons = [float(p[0]) for p in ring]
        lats = [float(p[1]) for p in ring]
        raw = (obj.get("attributes") or {}).get("elevation_m")
        if not isinstance(raw, list) or len(raw) < 2:
            raise ValueError(f"terrain {name!r}: elevation_m must be a list of at least "
                             "2 rows")
        width = len(raw[0]) if isinstance(raw[0], list) else 0
        if width < 2 or len(raw) * width > MAX_NODES:
            raise ValueError(f"terrain {name!r}: elevation_m rows need 2 or more values "
                             f"(at most {MAX_NODES} nodes in all)")
        rows = []
        for i, row in enumerate(raw):
            if not isinstance(row, list) or len(row) != width:
                raise ValueError(f"terrain {name!r}: elevation_m row {i} must have {width} "
                                 "values, like row 0")
            for j, value in enumerate(row):
                if isinstance(value, bool) or not isinstance(value, (int, float)) \
                        or not math.isfinite(value):
                    raise ValueError(f"terrain {name!r}: elevation_m[{i}][{j}] must be a "
                                     f"finite number, not {value!r}")
            rows.append(tuple(float(v) for v in row))
        return cls(str(name), min(lons), min(lats), max(lons), max(lats), tuple(rows))

    def elevation(self, lat: float, lon: float) -> float | None:
        """Bilinear elevation at a point; None outside the grid."""
        if not (self.west <= lon <= self.east and self.south <= lat <= self.north):
            return None
        y = (lat - self.south) / (self.north - self.south) * (len(self.rows) - 1)
        x = (lon - self.west) / (self.east - self.west) * (len(self.rows[0]) - 1)
        i, j = min(int(y), len(self.rows) - 2), min(int(x), len(self.rows[0]) - 2)
        fy, fx = y - i, x - j
        low = self.rows[i][j] * (1 - fx) + self.rows[i][j + 1] * fx
        high = self.rows[i + 1][j] * (1 - fx) + self.rows[i + 1][j + 1] * fx
        return low * (1 - fy) + high * fy

    def spacing_m(self) -> float:
        """The smaller node spacing, in metres."""
        mid = (self.south + self.north) / 2
        dx = distance_m(mid, self.west, mid, self.east) / (len(self.rows[0]) - 1)
        dy = distance_m(self.south, self.west, self.north, self.west) / (len(self.rows) - 1)
        return min(dx, dy)

    def steepest(self, a: tuple[float, float], b: tuple[float, float]) -> Stretch | None:
        """The steepest stretch of the segment a -> b ((lat, lon) each) on this grid;
        None when the segment does not cross it."""
        length = distance_m(*a, *b)
        steps = max(1, min(10_000, math.ceil(length / (self.spacing_m() / 2))))
        points = [(a[0] + (b[0] - a[0]) * k / steps, a[1] + (b[1] - a[1]) * k / steps)
                  for k in range(steps + 1)]
        best: Stretch | None = None
        previous: tuple[tuple[float, float], float] | None = None
        for point in points:
            z = self.elevation(*point)
            if z is None:
                previous = None
                continue
            if previous is not None:
                run = distance_m(*previous[0], *point)
                if run > 0:
                    slope = math.degrees(math.atan(abs(z - previous[1]) / run))
                    if best is None or slope > best.slope_deg:
                        best = Stretch(slope, previous[0], point)
            previous = (point, z)
        return best
