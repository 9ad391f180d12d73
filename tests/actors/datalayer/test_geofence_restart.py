"""What the geofence told outlives the data layer process (mrss.actors.datalayer.told_percepts):
a new geofence over the same store file takes back, replaces or tells again what the
previous one left with the agent, and sends again the removals it may not have got
through. The processes themselves: projects/amadee/procedures/test_amadee_geofence.py."""

from __future__ import annotations

from pathlib import Path

from mrss.actors.datalayer.geofence import EXIT, Finding, Geofence
from mrss.actors.datalayer.told_percepts import Told, ToldPercepts
from mrss.api.testing import memory_world
from mrss.messages import Percept
from mrss.runtime.percepts import PerceptPublisher

LAT, LON = 39.7700, 44.8000
D = 0.0001
MARSH = {"id": "marsh", "kind": "no_go", "geometry": {"type": "Polygon", "coordinates": [[
    [LON - 10 * D, LAT - 10 * D], [LON + D, LAT - 10 * D], [LON + D, LAT + 10 * D],
    [LON - 10 * D, LAT + 10 * D], [LON - 10 * D, LAT - 10 * D]]]}}
OUT = (LAT, LON + 3 * D)


class Incarnation:
    """One data layer's geofence over the store file `path` (a clock it owns)."""

    def __init__(self, path: Path, *, fresh: bool = False, acked: bool = True) -> None:
        self.sent: list[Percept] = []
        self.now = 100.0
        self.acked = acked
        self.store = ToldPercepts(path, fresh=fresh)
        geofence = Geofence.configured({"geofence": True}, memory_world([MARSH]),
                                       PerceptPublisher(lambda p, _id: self.sent.append(p)),
                                       told=self.store, settled=lambda: self.acked)
        assert geofence is not None
        geofence.clock = lambda: self.now
        self.geofence = geofence

    def look(self, lat: float, lon: float) -> Finding | None:
        self.now += 1.0
        return self.geofence.observe("ugv1", {"type": "position", "lat": lat, "lon": lon,
                                              "speed": 0.0})

    def said(self) -> list[tuple[str, str]]:
        return [(p.op, p.literal) for p in self.sent]


def told_exit(path: Path) -> str:
    first = Incarnation(path, fresh=True)
    assert first.look(LAT, LON) is Finding.EXIT
    [(op, text)] = first.said()
    assert op == "add" and text.startswith(f"{EXIT}(ugv1,marsh,")
    assert first.store.rows(Told.HELD) == [("ugv1", text)]
    return text   # the process dies here: nothing closed, nothing flushed


def test_the_next_incarnation_takes_back_what_the_previous_one_told(tmp_path: Path) -> None:
    path = tmp_path / "datalayer-geofence.sqlite3"
    text = told_exit(path)
    second = Incarnation(path)
    assert second.said() == []                        # nothing until it looks
    assert second.look(*OUT) is Finding.OUTSIDE      # the robot left meanwhile
    assert second.said() == [("remove", text)]
    assert second.store.rows(Told.HELD) == []
    assert second.store.rows(Told.WITHDRAWN) == []   # acknowledged: forgotten
    second.look(*OUT)
    assert second.said() == [("remove", text)]       # once


def test_unchanged_it_is_told_again_and_moved_it_is_replaced(tmp_path: Path) -> None:
    path = tmp_path / "datalayer-geofence.sqlite3"
    text = told_exit(path)
    second = Incarnation(path)
    assert second.look(LAT, LON) is Finding.EXIT
    assert second.said() == [("add", text)]   # the agent holds it: no news to it
    second.look(LAT, LON)
    assert second.said() == [("add", text)]
    third = Incarnation(path)
    assert third.look(LAT - 5 * D, LON - 5 * D) is Finding.EXIT   # stopped elsewhere
    [removed, added] = third.said()
    assert removed == ("remove", text) and added[0] == "add" and added[1] != text
    assert third.store.rows(Told.HELD) == [("ugv1", added[1])]


def test_a_removal_not_yet_acknowledged_is_sent_again_by_the_next(tmp_path: Path) -> None:
    path = tmp_path / "datalayer-geofence.sqlite3"
    first = Incarnation(path, fresh=True, acked=False)
    first.look(LAT, LON)
    [(_, text)] = first.said()
    first.look(*OUT)
    assert first.said()[1:] == [("remove", text)]
    assert first.store.rows(Told.WITHDRAWN) == [("ugv1", text)]   # killed before the ack
    second = Incarnation(path, acked=False)
    assert second.said() == [("remove", text)]        # at its start, before any look
    second.look(*OUT)
    assert second.store.rows(Told.WITHDRAWN) == [("ugv1", text)]
    second.acked = True
    second.look(*OUT)
    assert second.store.rows(Told.WITHDRAWN) == []
    assert second.said() == [("remove", text)]


def test_a_percept_killed_before_it_was_sent_is_still_taken_back(tmp_path: Path) -> None:
    path = tmp_path / "datalayer-geofence.sqlite3"

    def dies(_percept: Percept, _id: str | None) -> None:
        raise RuntimeError("killed between the store and the bus")

    store = ToldPercepts(path, fresh=True)
    geofence = Geofence.configured({"geofence": True}, memory_world([MARSH]),
                                   PerceptPublisher(dies), told=store)
    assert geofence is not None
    assert geofence.observe("ugv1", {"type": "position", "lat": LAT, "lon": LON,
                                     "speed": 0.0}) is None
    [(_, text)] = store.rows(Told.HELD)               # written before it was sent
    second = Incarnation(path)
    second.look(*OUT)
    assert second.said() == [("remove", text)]        # harmless if it never arrived


def test_the_first_incarnation_of_a_run_starts_empty(tmp_path: Path) -> None:
    path = tmp_path / "datalayer-geofence.sqlite3"
    told_exit(path)
    fresh = Incarnation(path, fresh=True)
    assert fresh.store.rows(Told.HELD) == []
    assert fresh.look(*OUT) is Finding.OUTSIDE and fresh.said() == []
