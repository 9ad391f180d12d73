"""MindInspector: the reasoner's beliefs, intentions (their stacks) and pending events.

Fed with `mind.<agent>` snapshots (`MindSnapshot`), requested by the app every second or
on a key. A snapshot that differs from the one shown changes only the nodes that differ
(a new belief is added in its place, a gone one removed, a changed intention relabelled),
and nodes the operator opened or closed stay that way.

History (`models/mind_history.py`): every snapshot that differs is kept with its time
and the reasoner's incarnation. `[` and `]` step back and forward through them, `f`
freezes the one shown (new ones are kept, not shown) or goes live again, `End` goes
live. The beliefs are marked against the snapshot before: `+` added, and a "removed"
branch lists those gone. The panel's subtitle says which snapshot shows.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any, ClassVar

from rich.cells import cell_len
from rich.text import Text
from textual.binding import Binding, BindingType
from textual.geometry import Region, Size
from textual.reactive import Reactive
from textual.widgets import Tree
from textual.widgets.tree import TreeNode

from mrss.messages import MindSnapshot
from mrss.tui.models.mind_history import MindEntry, MindHistory
from mrss.tui.widgets.border_text import set_border_subtitle
from mrss.tui.widgets.steady_scroll import SteadyScroll

OPEN_BY_DEFAULT = ("beliefs", "intentions", "events", "removed")


class MindInspector(SteadyScroll, Tree[str]):
    """A tree: agent > beliefs / intentions > stack frames / events."""

    #: its size changing repaints nothing by itself: `_invalidate` repaints the lines
    #: that changed (SteadyScroll still lays out when a scrollbar comes or goes)
    virtual_size: Reactive[Size] = Reactive(Size(0, 0), layout=False, repaint=False)
    BINDINGS: ClassVar[list[BindingType]] = [
        Binding("left_square_bracket", "older", "Older snapshot"),
        Binding("right_square_bracket", "newer", "Newer snapshot"),
        Binding("f", "freeze", "Freeze / live"),
        Binding("end", "live", "Live", show=False),
    ]

    def __init__(self, *, id: str | None = None) -> None:
        super().__init__("mind: no snapshot yet (m asks for one)", data="", id=id)
        self.snapshot: MindSnapshot | None = None
        self.received_at: float | None = None
        self.history = MindHistory()
        self.shown: MindEntry | None = None
        self._expanded_keys: set[str] = set(OPEN_BY_DEFAULT)
        self._collapsed_keys: set[str] = set()
        self._seen: set[str] = set()
        self._drawing = False  # a snapshot is being drawn: one invalidation at its end
        self._invalid = False
        self._built: dict[int, Shape] = {}  # node id -> the shape it was made or set from
        self._intentions: dict[str, Shape] = {}  # an intention's data (repr) -> its shape
        self._leaf_shapes: dict[tuple[str, bool], Shape] = {}  # (key, fresh) -> leaf
        self._painted: list[tuple[object, ...]] | None = None  # `_lines_in_view` painted

    def _invalidate(self) -> None:
        """Textual's Tree lays the whole screen out again at every node added or
        removed; this panel's size does not depend on its content, so it only repaints
        itself (SteadyScroll lays out when a scrollbar comes or goes), and while a
        snapshot is being drawn only once, at its end. Replaces `Tree._invalidate`
        (textual 8): the line cache, the node's update counter, the width cache, then a
        repaint instead of a layout."""
        if self._drawing:
            self._invalid = True
            return
        self._clear_line_cache()
        self._updates += 1
        self.root._reset()
        # The lines now, not when the next frame paints them: building them sets the
        # virtual size, and a scrollbar changed while a frame paints takes a frame of
        # its own (one a snapshot, `mrss bench tui`); then only the lines in view that
        # show another node, or the same one otherwise, are repainted (a snapshot that
        # adds a belief below the view repaints nothing)
        shown = self._lines_in_view()
        before, self._painted = self._painted, shown
        if before is None or len(before) != len(shown) or before[0] != shown[0]:
            self.refresh()
            return
        for y, (old, new) in enumerate(zip(before[1:], shown[1:], strict=True)):
            if old != new:
                self.refresh(Region(0, y, self.size.width, 1))

    def _relabel(self, node: TreeNode[str], label: Text) -> None:
        """A node's new label while a snapshot is drawn: `TreeNode.set_label` without
        its repaint of the node's whole subtree (a branch's count changing repainted
        every belief in view); the line is repainted with the others that changed when
        the drawing ends (`_invalidate` compares the labels in view)."""
        node._updates += 1
        node._label = self.process_label(label)
        self._invalid = True

    def _lines_in_view(self) -> list[tuple[object, ...]]:
        """What each line in view draws: its node's label (compared by its text and
        styles) and expansion, the path of nodes to it, each with whether it is its
        parent's last (the guides), and whether the cursor is on it; the first entry is
        the view (scrolled, resized: everything is repainted)."""
        top, cursor = self.scroll_offset.y, self.cursor_line
        lines = self._tree_lines[top:top + self.size.height]
        return [(top, self.size), *(
            (line.last, top + y == cursor, line.node._label, line.node.is_expanded,
             line.node.allow_expand, *((id(node), node.is_last) for node in line.path))
            for y, line in enumerate(lines))]

    def get_label_width(self, node: TreeNode[str]) -> int:
        """The width of a node's line without rendering its label: Textual's Tree
        renders every label to measure it each time it lays its lines out again, which
        it does at every snapshot that changed anything (~200 labels a second was a
        third of what the mind panel cost). The same width as `render_label`'s: the
        toggle icon of a branch, then the label."""
        label = node.label
        width = label.cell_len if isinstance(label, Text) else cell_len(label)
        if node.allow_expand:
            icon = self.ICON_NODE_EXPANDED if node.is_expanded else self.ICON_NODE
            return cell_len(icon) + width
        return width

    def show_snapshot(self, snap: MindSnapshot, when: float, incarnation: int = 0) -> None:
        """A snapshot arrived: kept in the history, shown if the inspector is live."""
        self.received_at = when
        self.history.add(snap, when, incarnation)
        if self.history.live:
            self._show_entry()
        else:
            self._subtitle()

    def forget(self) -> None:
        """Drop every snapshot kept (a replay moved its cursor: they are another time's)."""
        self.history = MindHistory()
        self.snapshot = None
        self.received_at = None
        self.shown = None
        self._built.clear()
        self.clear()
        self.root.set_label("mind: no snapshot at this moment of the recording")
        set_border_subtitle(self, "")

    def _subtitle(self) -> None:
        entry = self.history.current()
        if entry is None:
            return
        at, total = self.history.position() + 1, len(self.history.entries)
        mode = "live" if self.history.live else "frozen" if at == total else "history"
        stamp = time.strftime("%H:%M:%S", time.localtime(entry.ts))
        set_border_subtitle(self, f"{mode} · {at}/{total} · {stamp} · incarnation "
                                  f"{entry.incarnation} · [ ] step, f freeze")

    def _show_entry(self) -> None:
        entry = self.history.current()
        self._subtitle()
        if entry is None or entry is self.shown:
            return
        self.shown = entry
        self._draw(entry.snapshot)

    def action_older(self) -> None:
        self.history.back()
        self._show_entry()

    def action_newer(self) -> None:
        self.history.forward()
        self._show_entry()

    def action_freeze(self) -> None:
        if self.history.live:
            self.history.freeze()
        else:
            self.history.follow()
        self._show_entry()

    def action_live(self) -> None:
        self.history.follow()
        self._show_entry()

    def _draw(self, snap: MindSnapshot) -> None:
        """Bring the tree to `snap`: only the nodes whose label or place changed are
        touched (a snapshot a second with ~150 beliefs and a few changed must not rebuild
        them all: that was most of what the dashboard spent on the mind). A subtree
        made from the same shape as before (an intention that did not change) is not
        even compared."""
        added, removed = self.history.diff()
        fresh = set(added)
        self._remember_expansion(self.root)
        self.snapshot = snap
        root_label = Text.assemble(("agent ", "dim"), (snap.agent, "bold"))
        if self.root.label != root_label:
            self._relabel(self.root, root_label)
        label = Text(f"beliefs ({len(snap.beliefs)})")
        if added or removed:
            label.append(f"  +{len(added)} -{len(removed)} since the one before", "dim")
        leaves, self._leaf_shapes = self._leaf_shapes, {}
        shape = [Shape("beliefs", label, self._leaves(
            leaves, ((belief, belief in fresh) for belief in snap.beliefs), _belief))]
        if removed:
            shape.append(Shape("removed", Text(f"removed since the one before "
                                               f"({len(removed)})", style="red"),
                               self._leaves(leaves, ((belief, False) for belief in removed),
                                            _gone, "removed")))
        intentions, self._intentions = self._intentions, {}
        shape.append(Shape("intentions", Text(f"intentions ({len(snap.intentions)})"),
                           [self._intention(intentions, data) for data in snap.intentions]))
        shape.append(Shape("events", Text(f"events ({len(snap.events)})"),
                           self._leaves(leaves, ((event_text(event), False)
                                                 for event in snap.events),
                                        _event, "events")))
        self._seen = set()
        for part in shape:
            part.branch_keys(self._seen)
        self._drawing = True
        try:
            self._sync(self.root, shape)
            if not self.root.is_expanded:  # (expanding again would repaint every line)
                self.root.expand()
        finally:
            self._drawing = False
        if self._invalid:
            self._invalid = False
            self._invalidate()
        self._expanded_keys &= self._seen | set(OPEN_BY_DEFAULT)  # forget intentions that are gone
        self._collapsed_keys &= self._seen

    def _sync(self, parent: TreeNode[str], shape: list[Shape]) -> None:
        """Make `parent`'s children `shape`, in order, reusing the nodes of the same key
        that are already in that order and changing only labels that differ."""
        wanted = {part.key for part in shape}
        kept: list[TreeNode[str]] = []
        for child in list(parent.children):
            if child.data in wanted:
                kept.append(child)
            else:
                self._drop(child)
        by_key = {child.data: child for child in kept}
        moved: set[int] = set()
        at = 0
        for part in shape:
            while at < len(kept) and id(kept[at]) in moved:
                at += 1
            node = by_key.get(part.key)
            if node is not None and at < len(kept) and kept[at] is node:
                at += 1
                if self._built.get(node.id) is part:
                    continue  # made from this very shape: nothing in it changed
                if node.label != part.label:
                    self._relabel(node, part.label)
            else:
                if node is not None:  # out of order: made again in its place
                    moved.add(id(node))
                    self._drop(node)
                before = kept[at] if at < len(kept) else None
                node = self._make(parent, part, before)
            self._built[node.id] = part
            if part.children is not None:
                self._sync(node, part.children)

    def _drop(self, node: TreeNode[str]) -> None:
        stack = [node]
        while stack:
            gone = stack.pop()
            self._built.pop(gone.id, None)
            stack.extend(gone.children)
        node.remove()

    def _make(self, parent: TreeNode[str], part: Shape,
              before: TreeNode[str] | None) -> TreeNode[str]:
        if part.children is None:
            return parent.add_leaf(part.label, data=part.key, before=before)
        node = parent.add(part.label, data=part.key, before=before)
        if ((part.open or part.key in self._expanded_keys)
                and part.key not in self._collapsed_keys):
            node.expand()
        return node

    def _leaves(self, memo: dict[tuple[str, bool], Shape],
                texts: Iterable[tuple[str, bool]], label: Callable[[str, bool], Text],
                scope: str = "") -> list[Shape]:
        """Leaves keyed by their text (and which time that text repeats), the same
        shapes as the draw before for the same text."""
        seen: dict[str, int] = {}
        shape = []
        for text, fresh in texts:
            n = seen[text] = seen.get(text, 0) + 1
            key = f"leaf:{scope}:{text}#{n}"
            leaf = memo.get((key, fresh)) or Shape(key, label(text, fresh))
            self._leaf_shapes[key, fresh] = leaf
            shape.append(leaf)
        return shape

    def _intention(self, memo: dict[str, Shape], data: dict[str, Any]) -> Shape:
        """An intention's subtree; the same shape as the draw before for the same data."""
        signature = repr(data)
        shape = memo.get(signature) or _intention(data)
        self._intentions[signature] = shape
        return shape

    def _remember_expansion(self, node: TreeNode[str]) -> None:
        for child in node.children:
            key = child.data
            if not key or not child.allow_expand:
                continue  # a leaf
            if child.is_expanded:
                self._expanded_keys.add(key)
                self._collapsed_keys.discard(key)
            else:
                self._collapsed_keys.add(key)
            self._remember_expansion(child)


@dataclass(frozen=True, eq=False)
class Shape:
    """A node the tree should have: its key (unique among its siblings), its label, its
    children (None: a leaf), and whether it opens when first shown (unless the operator
    closed it before)."""

    key: str
    label: Text
    children: list[Shape] | None = None
    open: bool = False

    def branch_keys(self, into: set[str]) -> None:
        if self.children is not None:
            into.add(self.key)
            for child in self.children:
                child.branch_keys(into)


def _belief(text: str, fresh: bool) -> Text:
    return Text.assemble(("+ ", "bold green"), (text, "green")) if fresh else Text(text)


def _gone(text: str, _: bool) -> Text:
    return Text.assemble(("- ", "bold red"), (text, "red"))


def _event(text: str, _: bool) -> Text:
    return Text(text)


def _intention(data: dict[str, Any]) -> Shape:
    """An intention: open (unless the operator closed it), its stack's top open too."""
    ident = data.get("id", "?")
    label = Text.assemble((f"#{ident} ", "bold"), (str(data.get("state", "")), "cyan"))
    if data.get("suspended"):
        label.append(" suspended", "magenta")
    if data.get("waiting_on"):
        label.append(f"  waiting on {data['waiting_on']}", "yellow")
    key = f"intention:{ident}"
    frames: list[Shape] = []
    stack = data.get("stack")
    for depth, frame in enumerate(stack if isinstance(stack, list) else []):
        if not isinstance(frame, dict):
            continue
        flabel = Text.assemble((str(frame.get("trigger", "?")), "bold"),
                               (f"  {frame.get('source', '')}", "dim"))
        lines: list[Text] = []
        if frame.get("next"):
            lines.append(Text.assemble(("next: ", "dim"), str(frame["next"])))
        bindings = frame.get("bindings")
        if isinstance(bindings, dict) and bindings:
            text = ", ".join(f"{k}={v}" for k, v in bindings.items())
            lines.append(Text.assemble(("bindings: ", "dim"), text))
        if frame.get("plan"):
            lines.append(Text.assemble(("plan: ", "dim"), str(frame["plan"])))
        scope = f"{key}/{depth}"
        frames.append(Shape(scope, flabel, [Shape(f"leaf:{scope}:{n}", line)
                                            for n, line in enumerate(lines)],
                            open=depth == 0))  # the top of the stack: what runs now
    return Shape(key, label, frames, open=True)


def event_text(event: str) -> str:
    """An event line as the reasoner sends it: `+!go(a)  (intention #4)`."""
    return event
