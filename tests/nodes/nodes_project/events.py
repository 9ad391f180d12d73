"""The nodes project's operator events: `mrss/ui/patrol` `{"goal": "g1", "robot": "ugv1"}`
-> `patrol_received(g1, ugv1)`."""

from __future__ import annotations

from mrss.api import ExternalAdapter, Field, JsonMapping

PATROL = JsonMapping("patrol_received", Field("goal", "atom"), Field("robot", "robot"))


class ProjectEvents(ExternalAdapter):
    def start(self) -> None:
        self.map_json("mrss/ui/patrol", PATROL)
