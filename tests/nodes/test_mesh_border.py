"""The incarnation border of a node's bus proxy (mrss/bus/border.py), on loopback: a real
MeshThread with base's incarnation key, and field as a raw CurveZMQ peer holding
field's node key and an incarnation key of its own. What field proves with its key
enters base re-minted with base's key (a keyed subscriber on base believes it, and its
`sup.start` announcement), numbered for field's run (`across_runs`); a claim field's
key does not prove, or any claim before field's key was heard, is refused and counted; a
claim of nobody passes as it came; a peer without a key (an older release) is warned of;
when field's root runs again with a new key and a later run, its incarnations from 1
again are believed above the last run's, while a proof of its last run (a recording of
another run) is refused; a restart of base's proxy numbers them the same; a run that
goes back is warned of."""

from __future__ import annotations

import logging
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import zmq

from mrss.bus import BusEndpoints, Subscriber
from mrss.bus.curve import generate, load_keys, load_public
from mrss.bus.incarnations import Incarnations, refusal_counts
from mrss.bus.mesh import MeshSettings, MeshThread
from mrss.messages import (
    Envelope,
    IncarnationKey,
    NodeBeat,
    Percept,
    SupEvent,
    across_runs,
    encode,
)
from mrss.testing import free_port, wait_until

UNPROVEN = "bus message from {}: an incarnation its supervisor did not start"


@pytest.fixture()
def folder() -> Iterator[Path]:
    path = Path(tempfile.mkdtemp(prefix="mrss-border-"))
    try:
        yield path
    finally:
        shutil.rmtree(path, ignore_errors=True)


def test_a_peers_proofs_enter_re_minted_and_its_forgeries_are_refused(
        folder: Path, caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.WARNING, logger="mrss.bus.mesh")
    keys = folder / "keys"
    for node in ("base", "field"):
        generate(keys, node)
    (folder / "base").mkdir()
    own = IncarnationKey.create(folder / "base")
    theirs = IncarnationKey(b"f" * 32, run=1_700_000_000_000)  # field's run, in ms

    def field_inc(inc: int, key: IncarnationKey = theirs) -> int:
        return across_runs(key.run, inc)  # what base's components know it by

    settings = MeshSettings("base", f"tcp://127.0.0.1:{free_port()}",
                            {"field": f"tcp://127.0.0.1:{free_port()}"}, str(keys),
                            {"base": ["rcl"], "field": ["beacon"]}, interval=0.1,
                            misses=100, max_skew=5.0)
    ep = BusEndpoints.ipc(folder).keyed(own.path)
    mesh = MeshThread(ep, settings).start()
    seen: list[Envelope] = []
    door = Incarnations("base's component")  # a component's door: base's key
    sub = Subscriber(ep, prefixes=["percept", "sup.start"], incarnations=door)
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

        def percept(literal: str, src: str, inc: int, cred: bytes) -> list[bytes]:
            return list(encode(Percept(literal=literal), src=src, inc=inc, cred=cred))

        def taken(literal: str) -> list[Envelope]:
            return [e for e in list(seen) if isinstance(e.body, Percept)
                    and e.body.literal == literal]

        def until(frames: list[list[bytes]], done: Any, message: str) -> Any:
            def step() -> Any:
                for f in frames:
                    peer.send_multipart(f)
                return done()
            return wait_until(step, timeout=10, interval=0.02, message=message)

        # before field's key is known: a claim is refused; a claim of nobody passes
        until([percept("early(1)", "beacon", 1, theirs.credential("beacon", 1)),
               percept("nobody(1)", "mrss-send", 0, b"")],
              lambda: taken("nobody(1)"), "an unclaimed percept")
        assert not taken("early(1)")
        keyless = NodeBeat(node="field", boot="b1", components=["beacon"])  # older release
        until([list(encode(keyless, src="node.field"))],
              lambda: "sends no incarnation key" in caplog.text, "a keyless peer warned of")
        assert not mesh.proxy.border.knows("field")
        beat = NodeBeat(node="field", boot="b1", components=["beacon"],
                        key=theirs.export(), run=theirs.run)
        until([list(encode(beat, src="node.field"))],
              lambda: mesh.proxy.border.knows("field"), "field's key learnt")

        # proven by field's key: enters with base's credential, believed by base's door
        got = until([percept("ok(1)", "beacon", 1, theirs.credential("beacon", 1))],
                    lambda: taken("ok(1)"), "a proven percept")[0]
        assert got.inc == field_inc(1)
        assert got.cred == own.credential("beacon", field_inc(1))
        start = SupEvent(event="start", child="beacon", supervisor="field", pid=1,
                         detail={"inc": 2, "cred": theirs.credential("beacon", 2).hex()})
        until([list(encode(start, src="supervisor"))],
              lambda: door.live("beacon") == field_inc(2), "the announced restart believed")
        until([percept("ok(2)", "beacon", 2, theirs.credential("beacon", 2))],
              lambda: taken("ok(2)"), "the restarted beacon's percept")

        # forged: a huge incarnation with a wrong credential, or one made with base's key
        until([percept("forged(1)", "beacon", 10**9, b"x" * 16),
               percept("forged(2)", "beacon", 10**9, own.credential("beacon", 10**9)),
               percept("nobody(2)", "mrss-send", 0, b"")],
              lambda: taken("nobody(2)"), "a percept after the forgeries")
        until([percept("ok(3)", "beacon", 2, theirs.credential("beacon", 2))],
              lambda: taken("ok(3)"), "the live beacon still heard")
        assert not taken("forged(1)") and not taken("forged(2)")
        assert door.live("beacon") == field_inc(2)
        assert refusal_counts()[UNPROVEN.format("beacon")] >= 3  # early(1), forged(1, 2)
        assert mesh.proxy.border.refused >= 3

        # field's root runs again: a new key, a later run, incarnations from 1 again
        again = IncarnationKey(b"g" * 32, run=theirs.run + 60_000)
        refused = mesh.proxy.border.refused
        new_beat = list(encode(NodeBeat(node="field", boot="b2", components=["beacon"],
                                        key=again.export(), run=again.run), src="node.field"))
        until([new_beat, percept("old(3)", "beacon", 3, theirs.credential("beacon", 3)),
               percept("nobody(3)", "mrss-send", 0, b"")],
              lambda: taken("nobody(3)") and mesh.proxy.border.refused > refused,
              "the last run's proof refused")
        fresh = until([percept("new(1)", "beacon", 1, again.credential("beacon", 1))],
                      lambda: taken("new(1)"), "the new run's first incarnation believed")[0]
        assert fresh.inc == field_inc(1, again) > field_inc(2)
        assert door.live("beacon") == field_inc(1, again)
        assert not taken("old(3)")
        stale = door.dropped
        until([percept("late(2)", "beacon", 2, theirs.credential("beacon", 2)),
               percept("nobody(4)", "mrss-send", 0, b"")],
              lambda: taken("nobody(4)"), "the last run's live incarnation, sent again")
        assert not taken("late(2)") and door.dropped == stale  # at the border

        # base's proxy restarts: the same numbers, from what field's beat says
        mesh.stop()
        mesh = MeshThread(ep, settings).start()
        until([new_beat, percept("new(2)", "beacon", 1, again.credential("beacon", 1))],
              lambda: taken("new(2)"), "the new run heard through base's new proxy")
        assert taken("new(2)")[0].inc == field_inc(1, again)

        # a run that goes back (a clock reset, no kept run directory) is warned of
        back = IncarnationKey(b"h" * 32, run=theirs.run)
        until([list(encode(NodeBeat(node="field", boot="b3", components=["beacon"],
                                    key=back.export(), run=back.run), src="node.field"))],
              lambda: "not above its last run" in caplog.text, "a run going back warned of")
    finally:
        peer.close(0)
        ctx.term()
        sub.close()
        mesh.stop()
