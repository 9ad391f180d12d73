"""MessagesScreen (`M`): the bus as MQTT Explorer shows a broker, from `TopicsModel`.

Left, the topics as a tree of levels (robot > uav1 > data), each node with its message
count and rate; right, the highlighted topic's latest message as pretty JSON (the
decoded envelope: topic, kind, src, inc, ts, id, body) and its last messages, newest
first. The screen redraws once a second while it is open (while it is closed the
dashboard's drains only count into the model); new topics appear in the tree, the
expanded state is kept. Esc, q or M closes it.
"""

from __future__ import annotations

from typing import ClassVar

from rich.syntax import Syntax
from rich.text import Text
from textual.app import ComposeResult
from textual.binding import Binding, BindingType
from textual.containers import Horizontal, Vertical, VerticalScroll
from textual.screen import ModalScreen
from textual.widgets import Footer, Static, Tree
from textual.widgets.tree import TreeNode

from mrss.tui.models.topics import HISTORY, TopicNode, TopicsModel, pretty_json, summary


class MessagesScreen(ModalScreen[None]):
    """The topic tree and the chosen topic's latest message and history."""

    DEFAULT_CSS = """
    MessagesScreen { background: $background; }
    MessagesScreen #topics { width: 2fr; border: round $accent; }
    MessagesScreen #topic-side { width: 3fr; }
    MessagesScreen #topic-latest-box { height: 2fr; border: round $primary-darken-2; }
    MessagesScreen #topic-history-box { height: 1fr; border: round $primary-darken-2; }
    MessagesScreen #topic-title { height: 1; padding: 0 1; text-style: bold; }
    """
    BINDINGS: ClassVar[list[BindingType]] = [
        Binding("escape,q,M", "close", "Close messages"),
    ]

    def __init__(self, model: TopicsModel) -> None:
        super().__init__()
        self.model = model
        self.topic = ""  # the highlighted topic ("" for a level that is no topic)
        self.latest_text = ""  # what the right side shows (tests, captures)
        self.history_text: list[str] = []
        self._topic_nodes: dict[str, TreeNode[str]] = {}

    def compose(self) -> ComposeResult:
        with Horizontal():
            tree: Tree[str] = Tree("bus", data="", id="topics")
            tree.show_root = True
            yield tree
            with Vertical(id="topic-side"):
                yield Static("", id="topic-title")
                with VerticalScroll(id="topic-latest-box"):
                    yield Static("", id="topic-latest")
                with VerticalScroll(id="topic-history-box"):
                    yield Static("", id="topic-history")
        yield Footer()

    def on_mount(self) -> None:
        self.query_one("#topic-latest-box").border_title = "latest message"
        self.query_one("#topic-history-box").border_title = f"history (last {HISTORY})"
        tree = self.query_one(Tree)
        tree.border_title = "Bus topics (count · msgs/s)"
        tree.root.expand()
        self.redraw()
        self.set_interval(1.0, self.redraw)
        tree.focus()

    def redraw(self) -> None:
        tree: Tree[str] = self.query_one(Tree)
        root = self.model.tree()
        tree.root.set_label(root.label())
        known = len(self._topic_nodes)
        self._grow(tree.root, root)
        chosen = self._topic_nodes.get(self.topic)
        if len(self._topic_nodes) != known and chosen is not None \
                and tree.cursor_node is not chosen:
            _ = tree.last_line  # lays the lines out again: the node's line is current
            tree.move_cursor(chosen)  # new nodes above it moved the cursor's line
        self._show_topic()

    def _grow(self, parent: TreeNode[str], node: TopicNode) -> None:
        for child in node.sorted_children():
            shown = self._topic_nodes.get(child.path)
            if shown is None:
                if child.children:
                    shown = parent.add(child.label(), data=child.path,
                                       expand=len(self._topic_nodes) < 30)
                else:
                    shown = parent.add_leaf(child.label(), data=child.path)
                self._topic_nodes[child.path] = shown
            else:
                shown.set_label(child.label())
                if child.children and not shown.allow_expand:
                    shown.allow_expand = True
            self._grow(shown, child)

    def on_tree_node_highlighted(self, event: Tree.NodeHighlighted[str]) -> None:
        event.stop()
        self.topic = event.node.data or ""
        self._show_topic()

    def on_tree_node_selected(self, event: Tree.NodeSelected[str]) -> None:
        event.stop()

    def select_topic(self, topic: str) -> bool:
        """Move the tree's cursor to `topic` (tests, the palette); False if unknown."""
        node = self._topic_nodes.get(topic)
        if node is None:
            return False
        parent = node.parent
        while parent is not None:
            parent.expand()
            parent = parent.parent
        tree: Tree[str] = self.query_one(Tree)
        _ = tree.last_line  # lays the lines out again: the node's line is current
        tree.move_cursor(node)
        self.topic = topic
        self._show_topic()
        return True

    def _show_topic(self) -> None:
        title = self.query_one("#topic-title", Static)
        latest = self.query_one("#topic-latest", Static)
        history = self.query_one("#topic-history", Static)
        env = self.model.latest(self.topic) if self.topic else None
        if env is None:
            under = self.topic or "the bus"
            title.update(Text(f"{under}: a level, not a topic; pick a topic below it"
                              if self.topic else "pick a topic (arrows, Enter opens a level)"))
            self.latest_text, self.history_text = "", []
            latest.update("")
            history.update("")
            return
        stats = self.model.topics[self.topic]
        title.update(Text(f"{self.topic}  ·  {stats.count} messages  ·  "
                          f"{stats.rate(self.model.clock()):.1f}/s"))
        self.latest_text = pretty_json(env)
        latest.update(Syntax(self.latest_text, "json", theme="ansi_dark", word_wrap=True,
                             background_color="default"))
        width = history.content_size.width or 160  # one line each, cut to the box
        self.history_text = [summary(e, width) for e in self.model.history(self.topic)]
        history.update(Text("\n".join(self.history_text), no_wrap=True, overflow="ellipsis"))

    def action_close(self) -> None:
        self.dismiss(None)
