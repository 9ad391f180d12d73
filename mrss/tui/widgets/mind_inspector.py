"""MindInspector: the reasoner's beliefs, intentions (their stacks) and pending events.

Fed with `mind.<agent>` snapshots (`MindSnapshot`), requested by the app every second or
on a key. The tree is rebuilt only when a snapshot differs from the one shown, and
nodes the operator opened or closed stay that way across rebuilds.

History (`models/mind_history.py`): every snapshot that differs is kept with its time
and the reasoner's incarnation. `[` and `]` step back and forward through them, `f`
freezes the one shown (new ones are kept, not shown) or goes live again, `End` goes
live. The beliefs are marked against the snapshot before: `+` added, and a "removed"
branch lists those gone. The panel's subtitle says which snapshot shows.
"""

from __future__ import annotations

import time
from typing import Any, ClassVar

from rich.text import Text
from textual.binding import Binding, BindingType
from textual.widgets import Tree
from textual.widgets.tree import TreeNode

from mrss.messages import MindSnapshot
from mrss.tui.models.mind_history import MindEntry, MindHistory

OPEN_BY_DEFAULT = ("beliefs", "intentions", "events", "removed")


class MindInspector(Tree[str]):
    """A tree: agent > beliefs / intentions > stack frames / events."""

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
        self.clear()
        self.root.set_label("mind: no snapshot at this moment of the recording")
        self.border_subtitle = ""

    def _subtitle(self) -> None:
        entry = self.history.current()
        if entry is None:
            return
        at, total = self.history.position() + 1, len(self.history.entries)
        mode = "live" if self.history.live else "frozen" if at == total else "history"
        stamp = time.strftime("%H:%M:%S", time.localtime(entry.ts))
        self.border_subtitle = (f"{mode} · {at}/{total} · {stamp} · incarnation "
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
        added, removed = self.history.diff()
        fresh = set(added)
        self._remember_expansion(self.root)
        self.snapshot = snap
        self._seen = set()
        self.clear()
        root = self.root
        root.set_label(Text.assemble(("agent ", "dim"), (snap.agent, "bold")))
        label = Text(f"beliefs ({len(snap.beliefs)})")
        if added or removed:
            label.append(f"  +{len(added)} -{len(removed)} since the one before", "dim")
        beliefs = self._branch(root, label, "beliefs")
        for belief in snap.beliefs:
            beliefs.add_leaf(Text.assemble(("+ ", "bold green"), (belief, "green"))
                             if belief in fresh else Text(belief))
        if removed:
            gone = self._branch(root, Text(f"removed since the one before ({len(removed)})",
                                           style="red"), "removed")
            for belief in removed:
                gone.add_leaf(Text.assemble(("- ", "bold red"), (belief, "red")))
        intentions = self._branch(root, f"intentions ({len(snap.intentions)})", "intentions")
        for intention in snap.intentions:
            self._intention(intentions, intention)
        events = self._branch(root, f"events ({len(snap.events)})", "events")
        for event in snap.events:
            events.add_leaf(Text(event_text(event)))
        root.expand()
        self._expanded_keys &= self._seen | set(OPEN_BY_DEFAULT)  # forget intentions that are gone
        self._collapsed_keys &= self._seen

    def _branch(self, parent: TreeNode[str], label: str | Text, key: str) -> TreeNode[str]:
        node = parent.add(label, data=key)
        self._seen.add(key)
        if key in self._expanded_keys and key not in self._collapsed_keys:
            node.expand()
        return node

    def _intention(self, parent: TreeNode[str], data: dict[str, Any]) -> None:
        ident = data.get("id", "?")
        label = Text.assemble((f"#{ident} ", "bold"), (str(data.get("state", "")), "cyan"))
        if data.get("suspended"):
            label.append(" suspended", "magenta")
        if data.get("waiting_on"):
            label.append(f"  waiting on {data['waiting_on']}", "yellow")
        key = f"intention:{ident}"
        self._expanded_keys.add(key)  # intentions open unless the operator closed them
        node = self._branch(parent, label, key)
        stack = data.get("stack")
        for depth, frame in enumerate(stack if isinstance(stack, list) else []):
            if not isinstance(frame, dict):
                continue
            flabel = Text.assemble((str(frame.get("trigger", "?")), "bold"),
                                   (f"  {frame.get('source', '')}", "dim"))
            if depth == 0:
                self._expanded_keys.add(f"{key}/0")  # the top of the stack: what runs now
            fnode = self._branch(node, flabel, f"{key}/{depth}")
            if frame.get("next"):
                fnode.add_leaf(Text.assemble(("next: ", "dim"), str(frame["next"])))
            bindings = frame.get("bindings")
            if isinstance(bindings, dict) and bindings:
                text = ", ".join(f"{k}={v}" for k, v in bindings.items())
                fnode.add_leaf(Text.assemble(("bindings: ", "dim"), text))
            if frame.get("plan"):
                fnode.add_leaf(Text.assemble(("plan: ", "dim"), str(frame["plan"])))

    def _remember_expansion(self, node: TreeNode[str]) -> None:
        for child in node.children:
            key = child.data
            if not key:
                continue  # a leaf
            if child.is_expanded:
                self._expanded_keys.add(key)
                self._collapsed_keys.discard(key)
            else:
                self._collapsed_keys.add(key)
            self._remember_expansion(child)


def event_text(event: str) -> str:
    """An event line as the reasoner sends it: `+!go(a)  (intention #4)`."""
    return event
