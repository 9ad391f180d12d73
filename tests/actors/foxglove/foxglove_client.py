"""A Foxglove WebSocket protocol client for the tests, as Foxglove itself speaks it: the
server's `serverInfo` and `advertise` (JSON text), the client's `subscribe`, the server's
message data (binary: opcode 1, subscription id u32 LE, log time u64 LE, the message).

The protocol's subprotocol name was `foxglove.websocket.v1`; the Foxglove SDK's server
(0.30) accepts only its new name for the same protocol, `foxglove.sdk.v1`, as Foxglove's
bridge 3.x does. Like today's clients (the Foxglove app, Lichtblick), this one offers
both names and speaks whichever the server picks."""

from __future__ import annotations

import json
import struct
import time
from dataclasses import dataclass, field
from typing import Any

from websockets.sync.client import ClientConnection, connect
from websockets.typing import Subprotocol

SUBPROTOCOLS = (Subprotocol("foxglove.websocket.v1"), Subprotocol("foxglove.sdk.v1"))
MESSAGE_DATA = 0x01
_HEAD = struct.Struct("<BIQ")


@dataclass
class FoxgloveClient:
    """One connection; `channels` by topic as advertised, `received` per subscription."""

    ws: ClientConnection
    server: dict[str, Any] = field(default_factory=dict)
    channels: dict[str, dict[str, Any]] = field(default_factory=dict)
    received: dict[int, list[tuple[int, Any]]] = field(default_factory=dict)

    @classmethod
    def open(cls, url: str) -> FoxgloveClient:
        ws = connect(url, subprotocols=list(SUBPROTOCOLS), open_timeout=30)
        assert ws.subprotocol in SUBPROTOCOLS
        return cls(ws)

    def close(self) -> None:
        self.ws.close()

    def take(self, timeout: float) -> None:
        """Handle what the server sends within `timeout` seconds (at least one frame
        if one comes)."""
        try:
            frame = self.ws.recv(timeout=timeout)
        except TimeoutError:
            return
        if isinstance(frame, str):
            message = json.loads(frame)
            if message["op"] == "serverInfo":
                self.server = message
            elif message["op"] == "advertise":
                for channel in message["channels"]:
                    self.channels[channel["topic"]] = channel
            elif message["op"] == "unadvertise":
                gone = set(message["channelIds"])
                self.channels = {t: c for t, c in self.channels.items() if c["id"] not in gone}
        else:
            opcode, subscription, log_time = _HEAD.unpack_from(frame)
            if opcode == MESSAGE_DATA:
                self.received.setdefault(subscription, []).append(
                    (log_time, json.loads(frame[_HEAD.size:])))

    def wait(self, condition: Any, timeout: float, what: str) -> Any:
        """Take frames until `condition()` is truthy; its value (AssertionError on timeout)."""
        deadline = time.monotonic() + timeout
        while True:
            value = condition()
            if value:
                return value
            left = deadline - time.monotonic()
            assert left > 0, f"timed out waiting for {what}"
            self.take(min(left, 0.5))

    def subscribe(self, subscription: int, topic: str) -> None:
        channel = self.channels[topic]
        self.ws.send(json.dumps({"op": "subscribe", "subscriptions": [
            {"id": subscription, "channelId": channel["id"]}]}))
