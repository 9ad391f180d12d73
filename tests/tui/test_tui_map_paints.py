"""The map's title (scale, mode) is set only when it changes: setting it makes Textual
paint the panel again, in a frame of its own, and the title was set at every draw
(`mrss bench tui`: a second frame for the map every second)."""

from __future__ import annotations

import asyncio
from typing import Any

from textual.app import App, ComposeResult

from mrss.messages import RobotData
from mrss.tui.models.map import MapModel
from mrss.tui.widgets.map_panel import MapPanel


class _Host(App[None]):
    CSS = "MapPanel { border: round $accent; }"

    def __init__(self, model: MapModel) -> None:
        super().__init__()
        self.model = model

    def compose(self) -> ComposeResult:
        yield MapPanel(self.model, id="map")


def _position(robot: str, lat: float, lon: float) -> RobotData:
    return RobotData(robot=robot, data={"type": "position", "lat": lat, "lon": lon})


def test_a_draw_that_keeps_the_title_asks_for_no_second_paint() -> None:
    async def body() -> None:
        model = MapModel()
        app = _Host(model)
        async with app.run_test(size=(80, 24)) as pilot:
            panel = app.query_one(MapPanel)
            await pilot.pause()
            assert "no positions yet" in str(panel.border_title)
            paints: list[str] = []
            refresh = panel.refresh

            def counting(*regions: Any, **kwargs: Any) -> Any:
                paints.append(str(panel.border_title))
                return refresh(*regions, **kwargs)

            panel.refresh = counting  # type: ignore[method-assign]
            model.apply_data(_position("uav1", 47.0, 15.4))
            model.apply_data(_position("ugv1", 47.002, 15.402))
            model.apply_data(_position("uav2", 47.001, 15.401))
            panel.refresh()
            await pilot.pause()
            await pilot.pause()
            title = str(panel.border_title)
            assert "no positions yet" not in title
            assert len(paints) == 2  # ours, and the new title's
            # a robot moves between the others: the same extent and scale, the same title
            first = panel.marker_cell("uav2")
            paints.clear()
            model.apply_data(_position("uav2", 47.0016, 15.4003))
            panel.refresh()
            await pilot.pause()
            await pilot.pause()
            assert str(panel.border_title) == title
            assert paints == [title]  # only ours
            assert panel.marker_cell("uav2") != first  # drawn where it went
            # the fleet spreads out: the scale, so the title, changes and is shown
            model.apply_data(_position("ugv1", 47.05, 15.45))
            panel.refresh()
            await pilot.pause()
            await pilot.pause()
            assert str(panel.border_title) != title

    asyncio.run(body())
