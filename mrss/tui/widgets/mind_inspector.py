"""MindInspector: the reasoner's beliefs, intentions (their stacks) and pending events.

Fed with `mind.<agent>` snapshots (`MindSnapshot`), requested by the app every second or
on a key. The tree is rebuilt only when a snapshot differs from the one shown, and
nodes the operator opened or closed stay that way across rebuilds.
"""

from __future__ import annotations

from typing import Any

from rich.text import Text
from textual.widgets import Tree
from textual.widgets.tree import TreeNode

from mrss.messages import MindSnapshot

OPEN_BY_DEFAULT = ("beliefs", "intentions", "events")


class MindInspector(Tree[str]):
    """A tree: agent > beliefs / intentions > stack frames / events."""

    def __init__(self, *, id: str | None = None) -> None:
        super().__init__("mind: no snapshot yet (m asks for one)", data="", id=id)
        self.snapshot: MindSnapshot | None = None
        self.received_at: float | None = None
        self._expanded_keys: set[str] = set(OPEN_BY_DEFAULT)
        self._collapsed_keys: set[str] = set()
        self._seen: set[str] = set()

    def show_snapshot(self, snap: MindSnapshot, when: float) -> None:
        self.received_at = when
        if snap == self.snapshot:
            return
        self._remember_expansion(self.root)
        self.snapshot = snap
        self._seen = set()
        self.clear()
        root = self.root
        root.set_label(Text.assemble(("agent ", "dim"), (snap.agent, "bold")))
        beliefs = self._branch(root, Text(f"beliefs ({len(snap.beliefs)})"), "beliefs")
        for belief in snap.beliefs:
            beliefs.add_leaf(Text(belief))
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
