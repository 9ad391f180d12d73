"""The fleetloss operator's events: `mrss/ui/sweep` `{"goal": "g1", "lat": -35.36, "lon":
149.16, "strips": 8}` -> `sweep_received(g1, -35.36, 149.16, 8)`."""

from __future__ import annotations

from mrss.api import ExternalAdapter, Field, JsonMapping

SWEEP = JsonMapping("sweep_received", Field("goal", "atom"), Field("lat", "lat"),
                    Field("lon", "lon"), Field("strips", "int"))


class ProjectEvents(ExternalAdapter):
    def start(self) -> None:
        self.map_json("mrss/ui/sweep", SWEEP)
