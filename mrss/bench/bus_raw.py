"""`RawLink`: plain pyzmq PUB/SUB between the two processes of `mrss bench bus`, the limit
the bus is measured against (unbatched, or batched as our publisher batches)."""

from __future__ import annotations

import time
from collections import deque

import msgpack
import zmq

from mrss.bus.publisher import BURST_GAP, MAX_BATCH, MAX_BATCH_BYTES, MAX_HOLD
from mrss.messages import SCHEMA_VERSION, Envelope, IdGenerator, Message, RobotData, encode


class RawLink:
    """The physical limit: a pyzmq PUB bound here, a SUB connected to the peer's PUB, no
    proxy. The same envelope bytes go out (MRSS `encode`); the receiver only unpacks the
    msgpack and fills the message objects, without the bus's validation.

    With `batching`, messages are batched as our Publisher batches them (a message less
    than BURST_GAP after the previous one joins a batch `[topic, envelope, ...]` of up to
    MAX_BATCH envelopes or MAX_BATCH_BYTES; a pause, another topic or `flush` sends it)
    and received without a poll per message (a non-blocking receive first, a poll only
    when nothing is waiting): the fair limit for a bus that batches."""

    def __init__(self, bind: str | None, peer: str, topics: list[str], src: str,
                 proxy_frontend: str | None = None, batching: bool = False) -> None:
        self.src = src
        self.batching = batching
        self._ids = IdGenerator()
        self._batch: list[bytes] = []  # [topic, envelope, ...] not yet sent
        self._batch_bytes = 0
        self._batch_since = 0.0
        self._last_publish = 0.0
        self._pending: deque[Envelope] = deque()  # the rest of a received batch
        self.sends = 0  # ZeroMQ messages sent (a batch counts once)
        ctx: zmq.Context[zmq.Socket[bytes]] = zmq.Context.instance()
        self.pub = ctx.socket(zmq.PUB)
        self.pub.setsockopt(zmq.LINGER, 0)
        self.pub.setsockopt(zmq.SNDHWM, 100_000)
        if proxy_frontend is not None:  # through a bare zmq.proxy: publish to its XSUB
            self.pub.connect(proxy_frontend)
        else:
            assert bind is not None
            self.pub.bind(bind)
        self.sub = ctx.socket(zmq.SUB)
        self.sub.setsockopt(zmq.LINGER, 0)
        self.sub.setsockopt(zmq.RCVHWM, 100_000)
        for topic in topics:
            self.sub.setsockopt(zmq.SUBSCRIBE, topic.encode())
        self.sub.connect(peer)

    def publish(self, msg: Message) -> None:
        topic, payload = encode(msg, src=self.src, msg_id=self._ids())
        if not self.batching:
            self.pub.send(topic, zmq.SNDMORE)
            self.pub.send(payload)
            self.sends += 1
            return
        now = time.perf_counter()
        burst = now - self._last_publish < BURST_GAP
        self._last_publish = now
        if self._batch and (not burst or self._batch[0] != topic
                            or now - self._batch_since > MAX_HOLD):
            self.flush()
        if not (burst or self._batch):
            self.pub.send(topic, zmq.SNDMORE)
            self.pub.send(payload)
            self.sends += 1
            return
        if not self._batch:
            self._batch, self._batch_since = [topic], now
        self._batch.append(payload)
        self._batch_bytes += len(payload)
        if len(self._batch) > MAX_BATCH or self._batch_bytes >= MAX_BATCH_BYTES:
            self.flush()

    def flush(self) -> None:
        """Send the batch held, if any."""
        batch, self._batch, self._batch_bytes = self._batch, [], 0
        if batch:
            self.pub.send_multipart(batch)
            self.sends += 1

    def recv(self, timeout: float) -> Envelope | None:
        if self._pending:
            return self._pending.popleft()
        sub = self.sub
        if self.batching:
            try:
                frames = sub.recv_multipart(zmq.NOBLOCK)
            except zmq.Again:
                if not sub.poll(int(timeout * 1000)):
                    return None
                frames = sub.recv_multipart()
            topic = frames[0].decode()
            self._pending.extend(_envelope(topic, payload) for payload in frames[1:])
            return self._pending.popleft() if self._pending else None
        if not sub.poll(int(timeout * 1000)):
            return None
        topic_frame = sub.recv()
        return _envelope(topic_frame.decode(), sub.recv())

    def close(self) -> None:
        self.sub.close(0)
        self.pub.close(0)


def _envelope(topic: str, payload: bytes) -> Envelope:
    """The envelope in `payload`, msgpack-unpacked into the message objects, unchecked."""
    env = msgpack.unpackb(payload, raw=False)
    body: RobotData = object.__new__(RobotData)
    body.__dict__.update(env["body"])
    result: Envelope = object.__new__(Envelope)
    result.__dict__.update(topic=topic, id=env["id"], ts=env["ts"], src=env["src"],
                           inc=env["inc"], body=body, v=SCHEMA_VERSION)
    return result
