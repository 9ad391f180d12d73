"""A node's bus proxy (mrss.bus.mesh) against a misbehaving peer, on loopback: real
ZeroMQ sockets with CurveZMQ. The peer holds field's real key (so it gets in) and sends
garbage envelopes, beats with a clock an hour off, beats of two processes as one node,
and beats naming another node; each is refused with a clear log line, the proxy keeps
running and lets field's good messages through once it behaves."""

from __future__ import annotations

import logging
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import msgpack
import pytest
import zmq

from mrss.bus import BusEndpoints, Stale, Subscriber
from mrss.bus.curve import generate, load_keys, load_public
from mrss.bus.mesh import MeshSettings, MeshThread
from mrss.errors import ConfigError
from mrss.messages import Envelope, NodeBeat, Percept, SupEvent, encode
from mrss.testing import free_port, wait_until


@pytest.fixture()
def folder() -> Iterator[Path]:
    path = Path(tempfile.mkdtemp(prefix="mrss-mesh-"))
    try:
        yield path
    finally:
        shutil.rmtree(path, ignore_errors=True)


def _frames(body: Any, *, shift: float = 0.0) -> list[bytes]:
    topic, payload = encode(body, src="field-peer")
    if shift:
        env = msgpack.unpackb(payload)
        env["ts"] += shift
        payload = msgpack.packb(env)
    return [topic, payload]


def test_a_peer_that_misbehaves_is_refused_and_logged(
        folder: Path, caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.INFO)
    keys = folder / "keys"
    for node in ("base", "field"):
        generate(keys, node)
    port = free_port()
    settings = MeshSettings("base", f"tcp://127.0.0.1:{port}",
                            {"field": f"tcp://127.0.0.1:{free_port()}"}, str(keys),
                            {"base": ["rcl"], "field": ["beacon"]}, interval=0.1, misses=100,
                            max_skew=5.0)
    ep = BusEndpoints.ipc(folder)
    mesh = MeshThread(ep, settings).start()
    seen: list[Envelope] = []
    sub = Subscriber(ep, prefixes=["sup.node_", "percept"], stale=Stale.KEEP)
    sub.start(seen.append)
    ctx: zmq.Context[zmq.Socket[bytes]] = zmq.Context()
    peer = ctx.socket(zmq.PUB)
    try:
        assert sub.wait_connected(5)
        field = load_keys(keys, "field")
        peer.setsockopt(zmq.LINGER, 0)
        peer.setsockopt(zmq.CURVE_PUBLICKEY, field.public)
        peer.setsockopt(zmq.CURVE_SECRETKEY, field.secret)
        peer.setsockopt(zmq.CURVE_SERVERKEY, load_public(keys, "base"))
        peer.connect(settings.inbox)

        def events(name: str, cause: str = "") -> list[SupEvent]:
            return [e.body for e in list(seen) if isinstance(e.body, SupEvent)
                    and e.body.event == name and cause in str(e.body.detail.get("cause"))]

        def percepts(literal: str) -> list[Envelope]:
            return [e for e in list(seen) if isinstance(e.body, Percept)
                    and e.body.literal == literal]

        def until(send: list[list[bytes]], done: Any, message: str) -> None:
            def step() -> Any:
                for frames in send:
                    peer.send_multipart(frames)
                return done()
            wait_until(step, timeout=10, interval=0.02, message=message)

        beat = NodeBeat(node="field", boot="b1", components=["beacon"])
        until([_frames(beat)], lambda: events("node_up"), "field up")

        # garbage from an authenticated peer: dropped, logged; good messages still pass
        until([[b"percept", b"\xc1garbage"], [b"percept"], _frames(Percept(literal="ok(1)"))],
              lambda: percepts("ok(1)"), "a good percept after garbage")
        assert "dropped malformed message" in caplog.text and "node field" in caplog.text

        # a clock an hour ahead: refused, its messages dropped, until its clock is right
        until([_frames(beat, shift=3600.0)], lambda: events("node_down", "clock_skew"),
              "field refused for its clock")
        assert "its clock is 3600." in caplog.text and "ahead of ours" in caplog.text
        peer.send_multipart(_frames(Percept(literal="late(1)")))
        until([_frames(beat)], lambda: len(events("node_up")) >= 2, "field back")
        until([_frames(Percept(literal="ok(2)"))], lambda: percepts("ok(2)"), "ok(2)")
        assert not percepts("late(1)")

        # field's key naming another node; then two processes both beating as field
        until([_frames(NodeBeat(node="base", boot="x"))],
              lambda: events("node_down", "impostor"), "an impostor refused")
        assert "sent a beat as node 'base'" in caplog.text
        until([_frames(NodeBeat(node="field", boot="b2")), _frames(beat)],
              lambda: events("node_down", "duplicate"), "a duplicate node refused")
        assert "two processes run as node 'field'" in caplog.text
        assert mesh.alive() and mesh.proxy.dropped > 0
    finally:
        peer.close(0)
        ctx.term()
        sub.close()
        mesh.stop()
    assert not mesh.alive()


def test_keys_with_loose_permissions_are_refused(folder: Path) -> None:
    public, secret = generate(folder, "base")
    assert secret.stat().st_mode & 0o777 == 0o600
    with pytest.raises(ConfigError, match="already"):
        generate(folder, "base")
    secret.chmod(0o640)
    with pytest.raises(ConfigError, match=r"may be read by others \(mode 0640\).*chmod 600"):
        load_keys(folder, "base")
    secret.chmod(0o600)
    public.chmod(0o666)
    with pytest.raises(ConfigError, match="may be changed by others"):
        load_public(folder, "base")
    public.chmod(0o644)
    public.write_text("not a key\n")
    with pytest.raises(ConfigError, match="not a CurveZMQ public key"):
        load_public(folder, "base")
    with pytest.raises(ConfigError, match="mrss keys PROJECT --node relay"):
        load_public(folder, "relay")
