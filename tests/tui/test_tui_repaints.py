"""The dashboard repaints only the lines whose look changed (`mrss bench tui`): a border
text set again repaints nothing and a new one its border line alone; a mind snapshot
that changes nothing in view repaints no line of the tree; a map whose drawing did not
change is not painted; a table at its `max-height` that gains a row does not lay the
screen out. Each is counted where Textual renders a widget's lines (its styles cache),
so a regression to a whole-panel repaint shows as a count, not a look."""

from __future__ import annotations

from typing import Any

from rich.text import Text
from textual.app import App, ComposeResult
from textual.containers import Vertical
from textual.widget import Widget
from textual.widgets import Static

from mrss.messages import MindSnapshot, RobotData
from mrss.tui.models.actions import ActionsModel
from mrss.tui.models.map import MapModel
from mrss.tui.widgets.actions_table import ActionsTable
from mrss.tui.widgets.border_text import set_border_subtitle, set_border_title
from mrss.tui.widgets.log_pane import LogView
from mrss.tui.widgets.map_panel import MapPanel
from mrss.tui.widgets.mind_inspector import MindInspector
from tests.tui.tui_helpers import run


def _count_lines(widget: Widget) -> list[int]:
    """The lines (widget coordinates, borders included) rendered from now on."""
    lines: list[int] = []
    cache: Any = widget._styles_cache
    render_line = cache.render_line

    def counting(styles: Any, y: int, *args: Any) -> Any:
        lines.append(y)
        return render_line(styles, y, *args)

    cache.render_line = counting
    return lines


def _screen_text(app: App[Any]) -> str:
    return "\n".join(strip.text for strip in app.screen._compositor.render_strips())


class _Boxed(App[None]):
    CSS = "Static { border: round white; height: 8; width: 40; }"

    def compose(self) -> ComposeResult:
        yield Static("\n".join(f"line {i}" for i in range(6)))


def test_a_border_text_set_again_repaints_nothing_and_a_new_one_only_its_line() -> None:
    async def body() -> None:
        app = _Boxed()
        async with app.run_test(size=(60, 12)) as pilot:
            box = app.query_one(Static)
            set_border_subtitle(box, "first")
            set_border_title(box, "the title")
            await pilot.pause()
            assert "first" in _screen_text(app) and "the title" in _screen_text(app)
            lines = _count_lines(box)
            set_border_subtitle(box, "first")
            set_border_title(box, "the title")
            await pilot.pause()
            assert lines == []
            set_border_subtitle(box, "second")
            await pilot.pause()
            assert lines == [7]  # the bottom border of an 8-line box
            assert "second" in _screen_text(app) and "first" not in _screen_text(app)
            set_border_title(box, "another")
            await pilot.pause()
            assert lines == [7, 0]
            assert "another" in _screen_text(app)
            set_border_subtitle(box, "[b]plain[/b] [ ] text")  # never markup
            await pilot.pause()
            assert "[b]plain[/b] [ ] text" in _screen_text(app)
            set_border_subtitle(box, "")
            await pilot.pause()
            assert "second" not in _screen_text(app) and "plain" not in _screen_text(app)
    run(body())


class _Mind(App[None]):
    CSS = "MindInspector { height: 12; border: round white; }"

    def compose(self) -> ComposeResult:
        yield MindInspector(id="mind")


def _snapshot(beliefs: list[str]) -> MindSnapshot:
    return MindSnapshot(agent="r", beliefs=beliefs, intentions=[], events=[])


def test_a_mind_snapshot_repaints_only_the_tree_lines_that_changed_in_view() -> None:
    async def body() -> None:
        app = _Mind()
        async with app.run_test(size=(80, 16)) as pilot:
            mind = app.query_one(MindInspector)
            beliefs = [f"b{i}(1)" for i in range(40)]
            mind.show_snapshot(_snapshot(beliefs), 1.0, 1)
            await pilot.pause()
            text = _screen_text(app)
            assert "b0(1)" in text and "b39(1)" not in text  # the end is out of view
            # a belief out of view changes (same count): the branch's label says so
            mind.show_snapshot(_snapshot([*beliefs[:-1], "b39(2)"]), 2.0, 1)
            await pilot.pause()
            assert "+1 -1 since the one before" in _screen_text(app)
            lines = _count_lines(mind)
            # another such change: only the subtitle's line (the snapshot's number in the
            # history) is painted
            mind.show_snapshot(_snapshot([*beliefs[:-1], "b39(3)"]), 2.5, 1)
            await pilot.pause()
            assert lines == [11]
            lines.clear()
            # the first belief changes: its line and the subtitle's
            mind.show_snapshot(_snapshot(["b0(2)", *beliefs[1:-1], "b39(3)"]), 3.0, 1)
            await pilot.pause()
            assert len(lines) == 2 and 11 in lines
            assert "b0(2)" in _screen_text(app) and "b0(1)" not in _screen_text(app)
            lines.clear()
            # a belief added at the top moves every line in view down: all repainted
            mind.show_snapshot(_snapshot(["a(0)", "b0(2)", *beliefs[1:-1], "b39(3)"]), 4.0, 1)
            await pilot.pause()
            assert len(lines) >= 9
            assert "a(0)" in _screen_text(app)
    run(body())


class _Map(App[None]):
    CSS = "MapPanel { height: 12; border: round white; }"

    def __init__(self) -> None:
        super().__init__()
        self.model = MapModel()

    def compose(self) -> ComposeResult:
        yield MapPanel(self.model, id="map")


def _position(robot: str, lat: float, lon: float) -> RobotData:
    return RobotData(robot=robot, data={"type": "position", "lat": lat, "lon": lon,
                                        "heading": 0.0})


def test_a_map_whose_drawing_did_not_change_is_not_painted_again() -> None:
    async def body() -> None:
        app = _Map()
        async with app.run_test(size=(80, 16)) as pilot:
            panel = app.query_one(MapPanel)
            app.model.apply_data(_position("uav1", 47.0, 15.0))
            app.model.apply_data(_position("uav2", 47.01, 15.01))
            app.model.apply_data(_position("ugv1", 47.004, 15.004))
            panel.redraw()
            await pilot.pause()
            lines = _count_lines(panel)
            # a move far below a dot, inside the fitted view: the same drawing
            app.model.apply_data(_position("ugv1", 47.004 + 1e-9, 15.004))
            panel.redraw()
            await pilot.pause()
            assert lines == []
            before = _screen_text(app)
            # a move across the map: painted
            app.model.apply_data(_position("ugv1", 47.008, 15.002))
            panel.redraw()
            await pilot.pause()
            assert lines and _screen_text(app) != before
    run(body())


class _Actions(App[None]):
    CSS = "Vertical { height: 10; } ActionsTable { border: round white; }"

    def __init__(self) -> None:
        super().__init__()
        self.model = ActionsModel()

    def compose(self) -> ComposeResult:
        with Vertical():
            yield ActionsTable(self.model, id="actions")


def test_a_table_at_its_max_height_gaining_a_row_does_not_lay_the_screen_out() -> None:
    from mrss.messages import ActionRequest

    async def body() -> None:
        app = _Actions()
        async with app.run_test(size=(100, 20)) as pilot:
            table = app.query_one(ActionsTable)

            def add(i: int) -> None:
                app.model.apply_request(ActionRequest(uuid=f"{i:032x}", name="cover",
                                                      args=["uav1"], robot="uav1"),
                                        float(i), "reasoner")
                table.refresh_rows(100.0)

            for i in range(3):  # a short table grows with its rows: laid out each time
                before = table.relayouts
                add(i)
                await pilot.pause()
                assert table.relayouts == before + 1
            for i in range(3, 12):  # past the 10 lines of its container
                add(i)
                await pilot.pause()
            assert table.show_vertical_scrollbar
            before = table.relayouts
            for i in range(12, 16):
                add(i)
                await pilot.pause()
            assert table.relayouts == before
            assert table.row_count == 16
    run(body())


class _Log(App[None]):
    CSS = "LogView { height: 10; width: 60; }"

    def compose(self) -> ComposeResult:
        yield LogView()


def _bar_column(app: App[Any], view: LogView) -> list[str]:
    region = view.region
    rows = app.screen._compositor.render_strips()[region.y:region.bottom]
    return [strip.text[region.right - 1] for strip in rows]


def test_a_scrollbar_is_repainted_only_when_its_thumb_moves_an_eighth_of_a_cell() -> None:
    async def body() -> None:
        app = _Log()
        async with app.run_test(size=(80, 20)) as pilot:
            view = app.query_one(LogView)
            for i in range(1000):  # a long log: its 10-line thumb is one cell
                view.write(Text(f"line {i}"))
            await pilot.pause()
            view.auto_scroll = False  # paused on its last lines (the operator reads)
            view.scroll_to(y=view.max_scroll_y - 200, animate=False)
            await pilot.pause()
            lines = _count_lines(view.vertical_scrollbar)
            painted = 0
            for i in range(1000, 1100):  # each line in its own frame: the thumb creeps up
                view.write(Text(f"line {i}"))
                await pilot.pause()
                if i % 25 == 0:  # what is shown is what a full repaint shows
                    shown = _bar_column(app, view)
                    painted += len(lines)
                    view.vertical_scrollbar.refresh()
                    await pilot.pause()
                    assert _bar_column(app, view) == shown, i
                    lines.clear()
            painted += len(lines)
            assert painted < 200, painted  # a repaint of the 10-line bar per line: 1,000
            lines.clear()
            for _ in range(40):  # scrolling down a line at a time moves it now and then
                view.scroll_to(y=view.scroll_y + 1, animate=False)
                await pilot.pause()
            shown = _bar_column(app, view)
            view.vertical_scrollbar.refresh()
            await pilot.pause()
            assert _bar_column(app, view) == shown
            assert len(lines) < 200, len(lines)  # a few moves of a thumb, not 40 repaints
    run(body())
