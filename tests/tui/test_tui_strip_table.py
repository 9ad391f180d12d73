"""StripTable (the dashboard's tables): rows rendered once and repainted only when their
cells change, the cursor kept on its row's key, keys and clicks, what a line shows."""

from __future__ import annotations

from typing import Any, ClassVar

from rich.text import Text
from textual.app import App, ComposeResult
from textual.geometry import Region

from mrss.tui.widgets.keyed_table import KeyedTable, cell
from mrss.tui.widgets.strip_table import StripTable
from tests.tui.tui_helpers import run, until


class Table(KeyedTable):
    COLUMNS = (("name", "name"), ("state", "state"), ("note", "note"))
    MAX_WIDTHS: ClassVar[dict[str, int]] = {"note": 8}


class TableApp(App[None]):
    CSS = "Table { height: 8; width: 40; }"

    def __init__(self) -> None:
        super().__init__()
        self.selected: list[str] = []
        self.highlighted: list[str] = []

    def compose(self) -> ComposeResult:
        yield Table()

    def on_strip_table_row_selected(self, event: StripTable.RowSelected) -> None:
        self.selected.append(event.row_key)

    def on_strip_table_row_highlighted(self, event: StripTable.RowHighlighted) -> None:
        self.highlighted.append(event.row_key)


def rows(*names: str, state: str = "ok") -> list[tuple[str, list[Text]]]:
    return [(name, [cell(name, "bold"), cell(state, "green"), cell("")]) for name in names]


def screen_lines(table: Table) -> list[str]:
    """What the screen shows of the table: its lines as last painted (a line not
    repainted after a change would still show the old text)."""
    width, height = table.region.size
    lines = [strip.text for strip in table.render_lines(Region(0, 0, width, height))]
    assert {len(line) for line in lines} == {width}
    return [line.rstrip() for line in lines]


def test_only_the_rows_whose_cells_changed_are_rendered_again() -> None:
    async def body() -> None:
        app = TableApp()
        async with app.run_test(size=(60, 12)) as pilot:
            table = app.query_one(Table)
            table.show(rows("r1", "r2", "r3", "r4"))
            await pilot.pause()
            assert table.renders == 4
            assert screen_lines(table)[:3] == [" name  state  note", " r1    ok", " r2    ok"]
            # the same cells again (new Text objects): nothing rendered, nothing repainted
            table.show(rows("r1", "r2", "r3", "r4"))
            await pilot.pause()
            assert table.renders == 4
            # one cell of one row changes: that row alone is rendered again
            changed = rows("r1", "r2", "r3", "r4")
            changed[2] = ("r3", [cell("r3", "bold"), cell("gone", "red"), cell("")])
            table.show(changed)
            await pilot.pause()
            assert table.renders == 5
            assert screen_lines(table)[3] == " r3    gone"
            # a style alone is a change too (Text equality ignores it)
            changed[2] = ("r3", [cell("r3", "bold"), cell("gone", "blue"), cell("")])
            table.show(changed)
            await pilot.pause()
            assert table.renders == 6
            # a new row on top moves the others down without rendering them again
            table.show([*rows("r0"), *changed])
            await pilot.pause()
            assert table.renders == 7 and table.rebuilds == 2  # the first show, this one
            assert [line.split()[0] for line in screen_lines(table)[1:6]] == [
                "r0", "r1", "r2", "r3", "r4"]
            # a wider cell widens its column: every row drawn is rendered again, a cell
            # wider than its column's cap is cut with an ellipsis, controls are blanks
            table.show([("r0", [cell("r0"), cell("ok"), cell("a\tlong note")]),
                        *changed])
            await pilot.pause()
            assert table.renders == 12
            assert screen_lines(table)[:2] == [" name  state  note", " r0    ok     a long …"]
    run(body())


def test_the_cursor_stays_on_its_row_when_rows_come_above_it() -> None:
    async def body() -> None:
        app = TableApp()
        async with app.run_test(size=(60, 12)) as pilot:
            table = app.query_one(Table)
            assert table.selected_key is None and table.row_count == 0
            table.show(rows("a", "b", "c"))
            table.move_cursor(row=1)
            assert (table.selected_key, table.cursor_row) == ("b", 1)
            table.show(rows("x", "a", "b", "c"))  # a new row on top
            assert (table.selected_key, table.cursor_row) == ("b", 2)
            table.show(rows("x", "b", "c"))  # a row above it goes
            assert (table.selected_key, table.cursor_row) == ("b", 1)
            # on the first row the cursor follows the newest row
            table.move_cursor(row=0)
            table.show(rows("y", "x", "b", "c"))
            assert (table.selected_key, table.cursor_row) == ("y", 0)
            # its row gone: back to the first row
            table.move_cursor(row=2)
            table.show(rows("y", "x", "c"))
            assert (table.selected_key, table.cursor_row) == ("y", 0)
            await pilot.pause()
            assert app.highlighted == ["a", "b", "x", "y", "b", "y"]
    run(body())


def test_keys_move_the_cursor_and_keep_it_in_view_enter_selects() -> None:
    async def body() -> None:
        app = TableApp()
        async with app.run_test(size=(60, 12)) as pilot:
            table = app.query_one(Table)
            names = [f"r{i:02d}" for i in range(20)]
            table.show(rows(*names))
            table.focus()
            await pilot.press("down", "down")
            assert table.cursor_row == 2
            await pilot.press("end")  # 7 rows in view under the header
            assert table.cursor_row == 19
            await until(pilot, lambda: table.scroll_y == 13, message="scrolled to the end")
            assert screen_lines(table)[-1].split()[0] == "r19"
            await pilot.press("pageup")
            assert table.cursor_row == 12
            await pilot.press("up", "enter")
            await until(pilot, lambda: app.selected == ["r11"], message="r11 selected")
            await pilot.press("home")
            assert table.cursor_row == 0
            await until(pilot, lambda: table.scroll_y == 0, message="scrolled to the top")
            await pilot.press("pagedown", "up")
            assert table.cursor_row == 6
            await pilot.press("home", "up")  # stays on the first row
            assert table.cursor_row == 0
    run(body())


def test_a_click_puts_the_cursor_on_a_row_and_a_second_click_selects_it() -> None:
    async def body() -> None:
        app = TableApp()
        app.CSS = "Table { height: 8; width: 40; border: round red; }"  # as the panels
        async with app.run_test(size=(60, 12)) as pilot:
            table: Any = app.query_one(Table)
            table.show(rows("a", "b", "c"))
            await pilot.pause()
            await pilot.click(Table, offset=(3, 3))  # the border, then the header
            assert table.selected_key == "b" and app.selected == []
            for nothing in ((3, 0), (3, 1), (3, 5), (0, 3)):  # border, header, no row
                await pilot.click(Table, offset=nothing)
            assert table.selected_key == "b" and app.selected == []
            await pilot.click(Table, offset=(20, 3))
            await until(pilot, lambda: app.selected == ["b"], message="b selected")
    run(body())


def test_a_cell_styled_in_parts_keeps_its_styles_and_its_column() -> None:
    async def body() -> None:
        app = TableApp()
        async with app.run_test(size=(60, 12)) as pilot:
            table = app.query_one(Table)
            parts = Text.assemble(("ab", "red"), ("c\nd", "blue"))
            table.show([("r1", [cell("r1"), cell("ok"), cell("n")]),
                        ("r2", [parts, cell("ok"), cell("n")])])  # not the cursor's row
            await pilot.pause()
            assert screen_lines(table)[1:3] == [" r1     ok     n", " abc d  ok     n"]
            red = [segment for segment in table.render_line(2) if segment.text == "ab"]
            assert red and red[0].style is not None and red[0].style.color is not None
            assert red[0].style.color.name == "red"
    run(body())


def test_an_auto_height_table_lays_the_screen_out_only_when_it_gets_taller() -> None:
    async def body() -> None:
        app = TableApp()
        app.CSS = "Table { width: 40; }"  # height: auto (its rows)
        async with app.run_test(size=(60, 12)) as pilot:
            table = app.query_one(Table)
            table.show(rows("a", "b"))
            await pilot.pause()
            assert table.region.height == 3
            before = table.relayouts
            table.show([("a", [cell("a much wider name"), cell("ok"), cell("")]),
                        *rows("b")])
            await pilot.pause()
            assert table.relayouts == before  # wider, not taller: repainted only
            assert screen_lines(table)[1] == " a much wider name  ok"
            table.show(rows("a", "b", "c"))
            await until(pilot, lambda: table.region.height == 4, message="a row taller")
            assert table.relayouts == before + 1
    run(body())
