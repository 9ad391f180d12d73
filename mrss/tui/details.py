"""Detail screens: Enter on a row opens everything the dashboard knows of it, live.

- an action: its full uuid, name, args, literal, robot, goal, priority, requester,
  state, reason, every progress value, its allocation when it is a task addressed to
  a role (the role, the holder, every bid published, the robots that held it), and the
  transition timeline with who (the sender) and why (reason, failure cause, the debug
  keys' notes);
- a component: state, pid, incarnation, its full last exit reason, the restart budget
  ("4 of 5 in 30 s", as its supervisor counts it in the tree it reports; restarts seen
  since the dashboard attached when the tree did not say), CPU and memory of
  its process (psutil, when it runs on this machine), and its last log lines;
- a robot: every telemetry field, and sparklines of battery, altitude and tank over
  the last five minutes.

Each screen redraws every second from the app's models (progress moves while it is
open); Esc, q or Enter closes it.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any, ClassVar

import psutil
from rich.text import Text
from textual.app import ComposeResult
from textual.binding import Binding, BindingType
from textual.containers import Vertical, VerticalScroll
from textual.screen import ModalScreen
from textual.widgets import Sparkline, Static

from mrss.messages import AllocationState
from mrss.tui.models.actions import ActionsModel
from mrss.tui.models.robots import HISTORY_SECONDS, RobotsModel
from mrss.tui.models.supervision import SupervisionModel
from mrss.tui.models.tasks import TaskView

LOG_TAIL = 12
SPARK_SERIES = (("battery", "battery %"), ("altitude", "altitude m"), ("tank", "tank L"))


def _stamp(ts: float) -> str:
    return time.strftime("%H:%M:%S", time.localtime(ts)) + f".{int(ts * 1000) % 1000:03d}"


class DetailScreen(ModalScreen[None]):
    """The frame: a title, a scrolling body redrawn every second, keys to close."""

    DEFAULT_CSS = """
    DetailScreen { align: center middle; }
    DetailScreen > Vertical { width: 90%; height: 90%; border: thick $accent;
                              background: $surface; padding: 0 1; }
    DetailScreen #detail-title { text-style: bold; height: 1; }
    DetailScreen Sparkline { height: 2; margin-bottom: 1; }
    """
    BINDINGS: ClassVar[list[BindingType]] = [
        Binding("escape,q,enter", "close", "Close"),
    ]

    def __init__(self, title: str, clock: Callable[[], float] = time.time) -> None:
        super().__init__()
        self.title_text = title
        self.clock = clock

    def compose(self) -> ComposeResult:
        with Vertical():
            yield Static(Text(self.title_text), id="detail-title")
            with VerticalScroll():
                yield from self.extra()
                yield Static("", id="detail-body")

    def extra(self) -> ComposeResult:
        yield from ()

    def on_mount(self) -> None:
        self.redraw()
        self.set_interval(1.0, self.redraw)

    def redraw(self) -> None:
        self.query_one("#detail-body", Static).update(self.body())

    def body(self) -> Text:
        raise NotImplementedError

    @property
    def body_text(self) -> str:
        return self.body().plain

    def action_close(self) -> None:
        self.dismiss(None)


def _pairs(text: Text, pairs: list[tuple[str, object]]) -> None:
    width = max((len(k) for k, _ in pairs), default=0)
    for key, value in pairs:
        text.append(f"{key:<{width}}  ", "dim")
        text.append(f"{value}\n")


class ActionDetail(DetailScreen):
    """One action, its request and its history; a task addressed to a role, its
    allocation too (every bid published, its holders)."""

    def __init__(self, model: ActionsModel, uuid: str, **kw: Any) -> None:
        super().__init__(f"Action {uuid}", **kw)
        self.model, self.uuid = model, uuid

    def body(self) -> Text:
        view = self.model.actions.get(self.uuid)
        text = Text()
        if view is None:
            return Text("no longer kept (the dashboard keeps the newest 1000 actions)")
        _pairs(text, [("uuid", view.uuid), ("name", view.name or "?"),
                      ("args", view.args), ("literal", view.literal or "-"),
                      ("robot", view.robot or "-"), ("goal", view.goal or "-"),
                      ("priority", "-" if view.priority is None else view.priority),
                      ("requester", view.requester or "not seen (attached late)"),
                      ("state", view.state), ("reason", view.reason or "-")])
        text.append("\nprogress\n", "bold")
        if view.progress:
            text.append(f"  {view.progress_text(80)}\n")
            _pairs(text, [(f"  {k}", v) for k, v in sorted(view.progress.items())])
        else:
            text.append("  none reported\n", "dim")
        task = self.model.tasks.tasks.get(self.uuid)
        if task is not None:
            _allocation(text, task)
        text.append("\ntimeline (when, state, who, why)\n", "bold")
        for entry in view.history:
            style = "bold yellow" if entry.state == "note" else ""
            text.append(f"  {_stamp(entry.ts)}  ", "dim")
            text.append(f"{entry.state:<10} ", style or "bold")
            text.append(f"{entry.who or '?':<22} ", "cyan")
            text.append(f"{entry.why}\n", style)
        if not view.history:
            text.append("  no transition seen (only its latest state)\n", "dim")
        return text


def _allocation(text: Text, task: TaskView) -> None:
    """The allocation of a task addressed to a role: what it asks, where it stands, each
    bid (rank order) and the robots that held it."""
    text.append("\nallocation\n", "bold")
    holder = task.robot if task.state is AllocationState.AWARDED else "none (waiting)"
    _pairs(text, [("  role", task.role), ("  state", task.state.value),
                  ("  holder", holder), ("  ranked by", task.evaluator or "?"),
                  ("  held by", " -> ".join(task.holders) or "nobody yet")])
    for change in task.reassignments:
        text.append(f"  {_stamp(change.ts)}  ", "dim")
        text.append(f"reassigned from {change.lost_from} to {change.robot}\n", "bold yellow")
    text.append(f"  bids ({max(task.bidders, len(task.bids))}, best first)\n", "dim")
    for bid in task.bids:
        text.append(f"    {bid.describe()}\n", "" if bid.fit else "dim")


class ComponentDetail(DetailScreen):
    """One supervised component or actor: its process, budget, resources and log."""

    def __init__(self, model: SupervisionModel, path: str, log_lines: Callable[[], list[str]],
                 budget: tuple[int, float] | None = None, **kw: Any) -> None:
        super().__init__(f"Component {path}", **kw)
        self.model, self.path = model, path
        self.log_lines, self.budget = log_lines, budget
        self._proc: psutil.Process | None = None

    def _resources(self, pid: int) -> str:
        if not pid:
            return "not running"
        try:
            if self._proc is None or self._proc.pid != pid:
                self._proc = psutil.Process(pid)
                self._proc.cpu_percent(None)  # the first call only starts the measure
                return f"CPU measuring... · memory {self._proc.memory_info().rss / 2**20:.1f} MiB"
            cpu = self._proc.cpu_percent(None)
            rss = self._proc.memory_info().rss / 2**20
        except (psutil.Error, OSError):
            return f"pid {pid} is not a process of this machine (or not visible)"
        return f"CPU {cpu:.1f} % of a core · memory {rss:.1f} MiB"

    def body(self) -> Text:
        node = self.model.nodes.get(self.path)
        if node is None:
            return Text("not in the tree any more")
        now = self.clock()
        budget = ("unknown (the project's [supervisor] intensity and period)"
                  if self.budget is None and node.budget is None else
                  node.budget_text(now, *(self.budget or (0, 0.0))))
        uptime = node.uptime(now)
        text = Text()
        _pairs(text, [("path", node.path), ("kind", node.kind), ("state", node.state),
                      ("pid", node.pid or "-"), ("incarnation", node.incarnation),
                      ("uptime", "-" if uptime is None else f"{uptime:.0f} s"),
                      ("restarts", f"{node.restarts} in total"),
                      ("restart budget", budget),
                      ("resources", self._resources(node.pid))])
        text.append("\nlast exit reason\n", "bold")
        text.append(f"  {node.last_reason or 'none'}\n")
        name = node.name
        lines = [line for line in self.log_lines() if f" {name}:" in line
                 or f"/{name}" in line or f" {name} " in line][-LOG_TAIL:]
        text.append(f"\nlast log lines ({len(lines)})\n", "bold")
        for line in lines:
            text.append(f"  {line}\n")
        return text


class RobotDetail(DetailScreen):
    """One robot: state, every telemetry field, and its sparklines."""

    def __init__(self, model: RobotsModel, robot: str, **kw: Any) -> None:
        super().__init__(f"Robot {robot}", **kw)
        self.model, self.robot = model, robot

    def extra(self) -> ComposeResult:
        for key, _ in SPARK_SERIES:
            yield Static("", id=f"spark-label-{key}")
            yield Sparkline([], id=f"spark-{key}")

    def redraw(self) -> None:
        super().redraw()
        view = self.model.robots.get(self.robot)
        for key, label in SPARK_SERIES:
            points = list(view.series.get(key, ())) if view is not None else []
            values = [v for _, v in points]
            caption = Text(f"{label}: ", style="bold")
            if values:
                span = points[-1][0] - points[0][0]
                caption.append(f"{values[-1]:.1f} now, {min(values):.1f} .. {max(values):.1f} "
                               f"over {span:.0f} s ({len(values)} samples, last "
                               f"{HISTORY_SECONDS / 60:.0f} min kept)", "dim")
            else:
                caption.append("no data", "dim")
            self.query_one(f"#spark-label-{key}", Static).update(caption)
            spark = self.query_one(f"#spark-{key}", Sparkline)
            spark.display = bool(values)  # nothing to draw: no bar (an empty one looks full)
            spark.data = values or [0.0]

    def body(self) -> Text:
        view = self.model.robots.get(self.robot)
        if view is None:
            return Text("unknown robot")
        text = Text()
        age = "-" if view.data_ts is None else f"{max(0.0, self.clock() - view.data_ts):.1f} s"
        _pairs(text, [("available", view.available), ("link", view.link),
                      ("teleop", view.teleop), ("reason", view.reason or "-"),
                      ("data age", age)])
        text.append("\ntelemetry\n", "bold")
        _pairs(text, [(f"  {k}", v) for k, v in view.fields()] or [("  none", "")])
        return text
