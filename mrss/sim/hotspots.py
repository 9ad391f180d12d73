"""Hidden hotspots of a simulated fire, and the UAV's thermal camera that finds them."""

from __future__ import annotations

import json
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mrss.errors import ConfigError
from mrss.links.geo import distance_m

DEFAULT_TEMPERATURE_C = 400.0


@dataclass(frozen=True)
class Hotspot:
    """A hot point on the ground the camera can see: its number, position and temperature."""

    id: int
    lat: float
    lon: float
    temperature: float = DEFAULT_TEMPERATURE_C


def _check_position(lat: float, lon: float, source: str) -> None:
    if not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0):
        raise ConfigError(f"hotspot position out of range: {lat}, {lon}", file=source)


def _from_fields(index: int, fields: list[str], source: str) -> Hotspot:
    if len(fields) not in (2, 3):
        raise ConfigError(f"hotspot {index + 1}: expected LAT,LON[,TEMP], got {fields}",
                          file=source)
    try:
        numbers = [float(f) for f in fields]
    except ValueError as exc:
        raise ConfigError(f"hotspot {index + 1}: {exc}", file=source) from None
    _check_position(numbers[0], numbers[1], source)
    temp = numbers[2] if len(numbers) == 3 else DEFAULT_TEMPERATURE_C
    return Hotspot(index + 1, numbers[0], numbers[1], temp)


def hotspots_from_records(records: Iterable[Mapping[str, Any]], source: str) -> list[Hotspot]:
    """Hotspots from dicts with lat, lon and optional id and temperature (e.g. project.toml)."""
    result: list[Hotspot] = []
    for index, record in enumerate(records):
        try:
            lat, lon = float(record["lat"]), float(record["lon"])
            temp = float(record.get("temperature", DEFAULT_TEMPERATURE_C))
            ident = int(record.get("id", index + 1))
        except (KeyError, TypeError, ValueError) as exc:
            raise ConfigError(f"hotspot {index + 1}: bad record {record!r}: {exc}",
                              file=source) from None
        _check_position(lat, lon, source)
        result.append(Hotspot(ident, lat, lon, temp))
    return result


def parse_hotspots(spec: str) -> list[Hotspot]:
    """Hotspots from a file (JSON list, or lines "LAT,LON[,TEMP]") or inline "LAT,LON;LAT,LON"."""
    spec = spec.strip()
    if not spec:
        return []
    path = Path(spec)
    if path.is_file():
        text = path.read_text(encoding="utf-8")
        if path.suffix == ".json":
            try:
                data = json.loads(text)
            except json.JSONDecodeError as exc:
                raise ConfigError(f"not JSON: {exc}", file=str(path)) from None
            if not isinstance(data, list) or not all(isinstance(r, dict) for r in data):
                raise ConfigError("expected a JSON list of {lat, lon} objects", file=str(path))
            return hotspots_from_records(data, str(path))
        lines = [ln.split("#", 1)[0].strip() for ln in text.splitlines()]
        entries = [ln for ln in lines if ln]
        source = str(path)
    else:
        entries = [e.strip() for e in spec.split(";") if e.strip()]
        source = "--hotspots"
    return [_from_fields(i, [f.strip() for f in e.split(",")], source)
            for i, e in enumerate(entries)]


class ThermalCamera:
    """A downward thermal camera: reports a hotspot each time it comes into view.

    A hotspot is in view when the vehicle is at least `min_alt_m` above home and within
    `radius_m` of it horizontally. It is reported again only after it left the view.
    """

    def __init__(self, hotspots: Iterable[Hotspot], radius_m: float = 25.0,
                 min_alt_m: float = 2.0) -> None:
        self.hotspots = list(hotspots)
        self.radius_m = radius_m
        self.min_alt_m = min_alt_m
        self._in_view: set[int] = set()
        self.seen: set[int] = set()

    def scan(self, lat: float, lon: float, relative_alt_m: float) -> list[Hotspot]:
        """Hotspots that came into view at this position (empty when none did)."""
        now: set[int] = set()
        if relative_alt_m >= self.min_alt_m:
            now = {h.id for h in self.hotspots
                   if distance_m(lat, lon, h.lat, h.lon) <= self.radius_m}
        fresh = [h for h in self.hotspots if h.id in now and h.id not in self._in_view]
        self._in_view = now
        self.seen.update(h.id for h in fresh)
        return fresh
