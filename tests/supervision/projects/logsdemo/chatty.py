"""A component that talks: a warning every `every` seconds (also on the bus's own logger),
or, with `flood = N`, N warnings as fast as it can once `<run_dir>/flood.go` exists."""

from __future__ import annotations

import logging
import threading

from mrss.runtime.component import Component, ComponentContext


class Chatty(Component):
    def __init__(self) -> None:
        self.ctx: ComponentContext | None = None
        self.thread: threading.Thread | None = None
        self.stopping = threading.Event()

    def start(self, ctx: ComponentContext) -> None:
        self.ctx = ctx
        self.thread = threading.Thread(target=self._talk, daemon=True)
        self.thread.start()

    def _talk(self) -> None:
        assert self.ctx is not None
        ctx = self.ctx
        flood = int(ctx.options.get("flood", 0))
        if flood:
            go = ctx.run_dir / "flood.go"
            while not go.exists():
                if self.stopping.wait(0.05):
                    return
            for i in range(flood):
                ctx.log.warning("flood line %d", i)
            (ctx.run_dir / f"{ctx.name}.flooded").write_text(str(flood))
            return
        n = 0
        while not self.stopping.wait(float(ctx.options.get("every", 0.2))):
            n += 1
            ctx.log.warning("%s says hello %d", ctx.name, n)
            logging.getLogger("mrss.bus").warning("%s via the bus logger %d", ctx.name, n)

    def stop(self) -> None:
        self.stopping.set()
        if self.thread is not None:
            self.thread.join(timeout=5)
