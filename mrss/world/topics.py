"""The world model's requests on the bus: the topics it serves and answers on.

A requester asks on `dl.request.wm` and hears its own replies on `dl.reply.wm.<src>`; an
error reply that starts with `UNAVAILABLE_PREFIX` says the store is down, not the request
wrong (the client then raises `WorldModelUnavailable`, a reason to try again).
"""

from __future__ import annotations

import re

WM_REQUEST_TOPIC = "dl.request.wm"
WM_REPLY_TOPIC = "dl.reply.wm"
_PLAIN_SRC = re.compile(r"[A-Za-z0-9_-]+")


def wm_reply_topic(src: str) -> str:
    """Where the world model answers a request from `src`: `dl.reply.wm.<src>`, so a
    requester hears its own replies, not every other's (the data layer's telemetry
    writes answer ~2 a second per robot); `dl.reply.wm` for a src that is not one plain
    topic level."""
    return f"{WM_REPLY_TOPIC}.{src}" if _PLAIN_SRC.fullmatch(src) else WM_REPLY_TOPIC
#: How an error reply says the store's database is down (not the request's fault).
UNAVAILABLE_PREFIX = "WorldStoreUnavailable: "
