"""A component of the field node: it only has to run there (its state is what is seen)."""

from __future__ import annotations

from mrss.api import Component, ComponentContext


class Beacon(Component):
    def start(self, ctx: ComponentContext) -> None:
        ctx.log.info("beacon up on its node")

    def stop(self) -> None:
        pass
