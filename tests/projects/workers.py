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


class Talker(Worker):
    """A worker that says `tick N` on its log topic every `every` seconds (0.1)."""

    def start(self, ctx: ComponentContext) -> None:
        super().start(ctx)
        self.ticks = threading.Thread(target=self._tick, args=(ctx,), daemon=True)
        self.ticks.start()

    def _tick(self, ctx: ComponentContext) -> None:
        from mrss.messages import LogRecord

        n = 0
        while not ctx._stop.wait(float(ctx.options.get("every", 0.1))):
            n += 1
            ctx.publisher.publish(LogRecord(component=ctx.name, level="INFO",
                                            message=f"tick {n}"))


class Listener(Worker):
    """A worker that repeats the ticks it takes from the topics `hears` (prefixes) as
    `heard <src> <inc> <message>` on its own: what a component acts on, made visible."""

    def start(self, ctx: ComponentContext) -> None:
        super().start(ctx)
        from mrss.bus import BusEndpoints, Subscriber
        from mrss.messages import Envelope, LogRecord

        def repeat(env: Envelope) -> None:
            if isinstance(env.body, LogRecord) and env.body.message.startswith("tick"):
                ctx.publisher.publish(LogRecord(
                    component=ctx.name, level="INFO",
                    message=f"heard {env.src} {env.inc} {env.body.message}"))

        self.sub = Subscriber(BusEndpoints.from_dict(ctx.bus),
                              prefixes=list(ctx.options["hears"]), name=ctx.name)
        self.sub.start(repeat)
        self.sub.wait_connected(5.0)

    def stop(self) -> None:
        self.sub.close()
        super().stop()
