"""A robot link in a process of its own, for failsafe tests that stop or kill it.

As a script: ``python failsafe_driver.py KIND ROBOT JSON_OPTIONS`` builds the link with
`create_link` (as an RCL does), starts it, prints what it reports as JSON lines
(``{"state": [up, reason]}``, ``{"telemetry": record}`` for status and failsafe
records) and runs the calls it reads on stdin: ``["method", [args], {kwargs}]`` answered
by ``{"reply": "method", "ok": bool, "error": str}``; ``["controller", [false]]`` makes
the link's controller check fail (a dead robot actor) or pass again.

In a test: `LinkProcess` starts it, collects its lines on a thread and waits on them.
"""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

SCRIPT = Path(__file__).resolve()
REPORTED_TELEMETRY = ("status", "failsafe")


# -- the process ------------------------------------------------------------------------------
def main(argv: list[str]) -> int:
    from mrss.links.errors import LinkError
    from mrss.links.factory import create_link

    kind, robot, options = argv[0], argv[1], json.loads(argv[2])
    out_lock = threading.Lock()

    def emit(obj: dict[str, Any]) -> None:
        with out_lock:
            sys.stdout.write(json.dumps(obj) + "\n")
            sys.stdout.flush()

    def on_telemetry(record: dict[str, Any]) -> None:
        if record["type"] in REPORTED_TELEMETRY:
            emit({"telemetry": record})

    link = create_link(robot, kind, options, on_link_state=lambda up, why: emit(
        {"state": [up, why]}), on_telemetry=on_telemetry)
    controller = threading.Event()
    controller.set()
    link.watch_controller(controller.is_set)
    link.start()

    def call(name: str, args: list[Any], kwargs: dict[str, Any]) -> None:
        try:
            getattr(link, name)(*args, **kwargs)
            emit({"reply": name, "ok": True, "error": ""})
        except (LinkError, ValueError) as exc:
            emit({"reply": name, "ok": False, "error": str(exc)})

    for line in sys.stdin:
        name, args, *rest = json.loads(line)
        if name == "controller":
            (controller.set if args[0] else controller.clear)()
            emit({"reply": name, "ok": True, "error": ""})
            continue
        threading.Thread(target=call, args=(name, args, rest[0] if rest else {}),
                         daemon=True).start()
    link.close()
    return 0


# -- the test side ----------------------------------------------------------------------------
class LinkProcess:
    """A running driver: its reported lines, calls into it, signals to it."""

    def __init__(self, log: Path, kind: str, robot: str, options: dict[str, Any]) -> None:
        self.lines: list[dict[str, Any]] = []
        self._lock = threading.Lock()
        with open(log, "ab") as err:
            self.proc = subprocess.Popen(
                [sys.executable, str(SCRIPT), kind, robot, json.dumps(options)],
                stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=err)
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for raw in self.proc.stdout:
            try:
                line = json.loads(raw)
            except ValueError:
                continue
            with self._lock:
                self.lines.append(line)

    def snapshot(self) -> list[dict[str, Any]]:
        with self._lock:
            return list(self.lines)

    def states(self) -> list[tuple[bool, str]]:
        return [(bool(x["state"][0]), str(x["state"][1])) for x in self.snapshot()
                if "state" in x]

    def telemetry(self, kind: str) -> list[dict[str, Any]]:
        return [x["telemetry"] for x in self.snapshot()
                if "telemetry" in x and x["telemetry"]["type"] == kind]

    def send(self, name: str, *args: Any, **kwargs: Any) -> None:
        assert self.proc.stdin is not None
        self.proc.stdin.write((json.dumps([name, list(args), kwargs]) + "\n").encode())
        self.proc.stdin.flush()

    def call(self, name: str, *args: Any, within: float = 30.0, **kwargs: Any) -> None:
        """Run `link.name(*args, **kwargs)` in the process; AssertionError unless it worked."""
        before = len([x for x in self.snapshot() if x.get("reply") == name])
        self.send(name, *args, **kwargs)
        deadline = time.monotonic() + within
        while True:
            replies = [x for x in self.snapshot() if x.get("reply") == name]
            if len(replies) > before:
                reply = replies[before]
                assert reply["ok"], f"{name}{args}: {reply['error']}"
                return
            assert time.monotonic() < deadline, f"no reply to {name} within {within:.0f}s"
            time.sleep(0.01)

    def signal(self, signum: int) -> None:
        self.proc.send_signal(signum)

    def close(self) -> None:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGCONT)
            self.proc.kill()
        self.proc.wait(timeout=10)
        for stream in (self.proc.stdin, self.proc.stdout):
            if stream is not None:
                try:
                    stream.close()
                except OSError:
                    pass


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
