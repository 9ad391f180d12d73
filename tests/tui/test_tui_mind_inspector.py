"""The mind inspector brings its tree to each new snapshot by changing only what differs:
the nodes of unchanged beliefs and intentions stay (the same nodes), new ones appear in
the snapshot's order, gone ones go, and what the operator closed stays closed; and the
screen is not laid out again for it (`mrss bench tui`: that was most of the mind's cost)."""

from __future__ import annotations

import asyncio
from typing import Any

from textual.app import App, ComposeResult
from textual.widgets.tree import TreeNode

from mrss.messages import MindSnapshot
from mrss.tui.widgets.mind_inspector import MindInspector


class _Host(App[None]):
    def compose(self) -> ComposeResult:
        yield MindInspector(id="mind")


def _intention(ident: int, state: str, trigger: str) -> dict[str, Any]:
    return {"id": ident, "state": state, "suspended": False, "waiting_on": "",
            "stack": [{"trigger": trigger, "source": "agent.asl:3", "next": "go",
                       "bindings": {"A": "a1"}, "plan": "p"}]}


def _branch(mind: MindInspector, key: str) -> TreeNode[str]:
    return next(node for node in mind.root.children if node.data == key)


def _labels(node: TreeNode[str]) -> list[str]:
    return [str(child.label) for child in node.children]


def test_a_new_snapshot_changes_only_the_nodes_that_differ() -> None:
    async def body() -> None:
        app = _Host()
        async with app.run_test(size=(100, 60)) as pilot:
            mind = app.query_one(MindInspector)
            mind.show_snapshot(MindSnapshot(
                agent="r", beliefs=["a", "b", "c", "d"],
                intentions=[_intention(1, "running", "+!x"), _intention(2, "running", "+!y")],
                events=["+e1"]), 1.0, 1)
            await pilot.pause()
            beliefs = _branch(mind, "beliefs")
            nodes = {str(node.label): node for node in beliefs.children}
            first = _branch(mind, "intentions").children[0]
            first.collapse()  # the operator closes intention 1
            second = _branch(mind, "intentions").children[1]
            layouts: list[bool] = []  # Textual's Tree lays the whole screen out per node
            refresh = mind.refresh

            def counting(*regions: Any, **kwargs: Any) -> Any:
                layouts.extend([True] if kwargs.get("layout") else [])
                return refresh(*regions, **kwargs)

            mind.refresh = counting  # type: ignore[method-assign]
            mind.show_snapshot(MindSnapshot(
                agent="r", beliefs=["a", "b2", "c", "e"],
                intentions=[_intention(1, "running", "+!x"), _intention(2, "waiting", "+!y"),
                            _intention(3, "running", "+!z")],
                events=[]), 2.0, 1)
            await pilot.pause()
            beliefs = _branch(mind, "beliefs")
            assert [node.label.plain for node in beliefs.children] == [  # type: ignore[union-attr]
                "a", "+ b2", "c", "+ e"]
            # a and c are the very nodes shown before; b and d went
            assert beliefs.children[0] is nodes["a"] and beliefs.children[2] is nodes["c"]
            assert _labels(_branch(mind, "removed")) == ["- b", "- d"]
            intentions = _branch(mind, "intentions")
            assert [str(n.label) for n in intentions.children] == [
                "#1 running", "#2 waiting", "#3 running"]
            assert intentions.children[0] is first and not first.is_expanded
            assert intentions.children[1] is second and second.is_expanded
            assert intentions.children[2].is_expanded  # new intentions open
            assert _labels(intentions.children[2].children[0]) == [
                "next: go", "bindings: A=a1", "plan: p"]
            assert _labels(_branch(mind, "events")) == []
            assert layouts == []  # nodes came and went; no scrollbar did: only a repaint
            # back to the first order with a belief moved: the tree follows exactly
            mind.show_snapshot(MindSnapshot(agent="r", beliefs=["c", "a"], intentions=[],
                                            events=["+e2"]), 3.0, 1)
            await pilot.pause()
            assert [n.label.plain for n in _branch(mind, "beliefs").children] == [  # type: ignore[union-attr]
                "c", "a"]
            assert _labels(_branch(mind, "intentions")) == []
            assert _labels(_branch(mind, "events")) == ["+e2"]
    asyncio.run(body())


def test_the_measured_width_of_every_line_is_the_width_of_its_rendered_label() -> None:
    """The inspector measures a line without rendering its label; the measure must be
    what Textual's Tree gets by rendering it (a branch open or closed, a leaf, a fresh
    belief's style, wide characters), or the panel scrolls too little or too far."""
    from textual.widgets import Tree

    async def body() -> None:
        app = _Host()
        async with app.run_test(size=(100, 60)) as pilot:
            mind = app.query_one(MindInspector)
            mind.show_snapshot(MindSnapshot(
                agent="r", beliefs=["a", "pos(uav1, 47.1, 15.4)", "note(\"火災 near 川\")"],
                intentions=[_intention(1, "running", "+!x"), _intention(2, "suspended", "+!y")],
                events=["+e1"]), 1.0, 1)
            await pilot.pause()
            mind.show_snapshot(MindSnapshot(
                agent="r", beliefs=["a", "b", "note(\"火災 near 川\")"],
                intentions=[_intention(1, "running", "+!x")], events=[]), 2.0, 1)
            await pilot.pause()
            _branch(mind, "intentions").children[0].collapse()
            await pilot.pause()
            nodes, stack = [], [mind.root]
            while stack:
                node = stack.pop()
                nodes.append(node)
                stack.extend(node.children)
            kinds = {(node.allow_expand, node.is_expanded) for node in nodes}
            assert {(True, True), (True, False), (False, False)} <= kinds
            for node in nodes:
                assert mind.get_label_width(node) == Tree.get_label_width(mind, node), \
                    str(node.label)

    asyncio.run(body())
