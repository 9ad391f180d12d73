"""Small worker components for the supervision tests and test projects.

Options (from project.toml or the test) shape their behaviour: `start_delay` seconds
in start, `crash_on_start`, `config_error_on_start`, `finish_after` seconds then a normal
exit, `stop_delay` seconds in stop, `grandchild` to spawn a helper process that it owns.
"""

from __future__ import annotations

import os
import subprocess
import sys
import threading
import time
from typing import Any

from mrss.errors import ConfigError
from mrss.runtime.component import Component, ComponentContext


class Worker(Component):
    """A component that does nothing but can be told to misbehave."""

    def __init__(self) -> None:
        self.ctx: ComponentContext | None = None
        self.helper: subprocess.Popen[Any] | None = None
        self.timer: threading.Timer | None = None

    def start(self, ctx: ComponentContext) -> None:
        self.ctx = ctx
        opts = ctx.options
        if opts.get("start_delay"):
            time.sleep(float(opts["start_delay"]))
        if opts.get("crash_on_start"):
            raise RuntimeError(f"{ctx.name} refuses to start")
        if opts.get("config_error_on_start"):
            raise ConfigError("bad value", file="project.toml", key=f"components.{ctx.name}")
        if opts.get("grandchild"):
            self.helper = subprocess.Popen(
                [sys.executable, "-c", "import time; time.sleep(600)"])
        if opts.get("finish_after") is not None:
            self.timer = threading.Timer(float(opts["finish_after"]), ctx.finish)
            self.timer.start()
        (ctx.run_dir / f"{ctx.name}.{ctx.incarnation}.started").write_text(str(os.getpid()))

    def stop(self) -> None:
        assert self.ctx is not None
        if self.timer is not None:
            self.timer.cancel()
        if self.ctx.options.get("stop_delay"):
            time.sleep(float(self.ctx.options["stop_delay"]))
        if self.helper is not None:
            self.helper.terminate()
            self.helper.wait()


class NotAComponent:
    """Named by a bad project.toml in tests: it does not subclass Component."""


class Announcer(Worker):
    """A worker that says on the bus which incarnation of it has started."""

    def start(self, ctx: ComponentContext) -> None:
        super().start(ctx)
        from mrss.messages import LogRecord

        ctx.publisher.publish(LogRecord(component=ctx.name, level="INFO",
                                        message=f"started incarnation {ctx.incarnation}"))
