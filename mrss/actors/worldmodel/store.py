"""The world model store: one interface, two backends, chosen by configuration.

- `SqliteWorldStore` (`mrss.actors.worldmodel.sqlite`): embedded, a file in the run folder
  or in memory; spatial predicates computed with shapely. The default.
- `PostgisWorldStore` (`mrss.actors.worldmodel.postgis`): PostgreSQL + PostGIS, selected by
  `[worldmodel] url = "postgresql://..."`; predicates computed in SQL.

Both satisfy `WorldStore` and pass the same tests
(tests/actors/worldmodel/test_worldmodel_backends.py).
Distances are metres on a sphere of the mean Earth radius in both. A backend that lost its
server raises `WorldStoreUnavailable` (a `DependencyUnavailable`) and reconnects later.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable
from urllib.parse import urlsplit

from mrss.actors.worldmodel.sqlite import SqliteWorldStore
from mrss.edge.retry import DependencyUnavailable
from mrss.world.geometry import EARTH_RADIUS_M, Geometry, haversine_m
from mrss.world.objects import Change, ChangeOp, Position, WorldObject, merge

__all__ = ["EARTH_RADIUS_M", "POSTGRES_SCHEMES", "Change", "ChangeOp", "Geometry", "Position",
           "SqliteWorldStore", "WorldModelStore", "WorldObject", "WorldStore",
           "WorldStoreUnavailable", "haversine_m", "merge", "postgres_url_problem"]


class WorldStoreUnavailable(DependencyUnavailable):
    """The store's database server cannot be reached (now); the request was not done,
    or, for a write in flight, may not have been done."""


@runtime_checkable
class WorldStore(Protocol):
    """What every world model backend provides (thread-safe)."""

    def close(self) -> None:
        """Release the database."""
        ...

    def upsert(self, obj: WorldObject, *, replace_attributes: bool = False) -> Change:
        """Insert `obj`, or update the object with its id (`worldmodel_objects.merge`).
        Returns once the write is durable in the backend."""
        ...

    def get(self, object_id: str) -> WorldObject | None:
        """The object with this id, or None."""
        ...

    def delete(self, object_id: str) -> bool:
        """Remove an object; False when there was none."""
        ...

    def objects(self, kind: str | None = None) -> list[WorldObject]:
        """Every object, or those of one kind, ordered by id."""
        ...

    def near(self, position: Position, radius_m: float,
             kind: str | None = None) -> list[tuple[WorldObject, float]]:
        """Objects whose shape is within `radius_m` metres of `position`, nearest first
        (then by id), with their distances in metres."""
        ...

    def intersecting(self, geometry: Geometry, kind: str | None = None) -> list[WorldObject]:
        """Objects whose shape shares a point with `geometry`, ordered by id."""
        ...

    def within(self, geometry: Geometry, kind: str | None = None) -> list[WorldObject]:
        """Objects whose shape lies inside `geometry` (not only on its boundary), by id."""
        ...

    def within_distance(self, geometry: Geometry, distance_m: float,
                        kind: str | None = None) -> list[tuple[WorldObject, float]]:
        """Objects within `distance_m` metres of `geometry`, nearest first, with distances."""
        ...


POSTGRES_SCHEMES = ("postgresql", "postgres")


def postgres_url_problem(value: str) -> str | None:
    """Why `value` is not a PostgreSQL URL for `[worldmodel] url`, or None."""
    try:
        parts = urlsplit(value)
        parts.port  # noqa: B018 (raises for a bad port)
    except ValueError as exc:
        return f"not a valid URL {value!r}: {exc}"
    if parts.scheme not in POSTGRES_SCHEMES or not parts.hostname:
        return (f"{value!r} is not a PostgreSQL URL; did you mean "
                "postgresql://user@host:5432/database? (leave url out for the embedded "
                "SQLite store)")
    return None


#: The embedded store under its historical name (`WorldModelStore(path)`).
WorldModelStore = SqliteWorldStore
