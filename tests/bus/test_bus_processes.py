"""The bus between real OS processes: pub/sub, a proxy killed mid-stream, the reliable channel."""

from __future__ import annotations

import time
from collections import Counter

import pytest

from mrss.bus import BusEndpoints
from mrss.testing import WaitTimeout, wait_until
from tests.bus.bus_helpers import BusProcess, Spawn


def _seqs(sub: BusProcess, robot: str) -> list[int]:
    """Sequence numbers `sub` printed for messages of publisher `robot`."""
    out = []
    for line in list(sub.lines[1:]):
        topic, src, seq = line.split()
        assert src == f"pub-{robot}" and topic == f"robot.{robot}.data", line
        out.append(int(seq))
    return out


def _seqs_by_robot(sub: BusProcess) -> dict[str, list[int]]:
    out: dict[str, list[int]] = {}
    for line in list(sub.lines[1:]):
        topic, _, seq = line.split()
        out.setdefault(topic.split(".")[1], []).append(int(seq))
    return out


def _contiguous(seqs: list[int]) -> bool:
    return seqs == list(range(seqs[0], seqs[0] + len(seqs)))


def test_pubsub_across_processes_delivers_in_order_by_prefix(
    endpoints: BusEndpoints, spawn: Spawn,
) -> None:
    spawn(endpoints, "proxy")
    only_a = spawn(endpoints, "sub", "robot.a.")
    everything = spawn(endpoints, "sub", "robot.")
    spawn(endpoints, "pub", "a")
    spawn(endpoints, "pub", "b")

    wait_until(lambda: len(_seqs(only_a, "a")) >= 200, 20, message="200 messages of a")
    wait_until(lambda: min(map(len, _seqs_by_robot(everything).values()), default=0) >= 200
               and len(_seqs_by_robot(everything)) == 2, 20, message="both publishers")

    # The prefix filter: robot.a. never sees b. Once joined, nothing is lost or reordered.
    assert _contiguous(_seqs(only_a, "a"))
    for seqs in _seqs_by_robot(everything).values():
        assert _contiguous(seqs)


def test_subscribers_resume_after_proxy_is_killed_and_restarted(
    endpoints: BusEndpoints, spawn: Spawn,
) -> None:
    proxy = spawn(endpoints, "proxy")
    sub = spawn(endpoints, "sub", "robot.")
    pub = spawn(endpoints, "pub", "a")
    wait_until(lambda: len(_seqs(sub, "a")) >= 50, 20, message="messages before the kill")

    proxy.kill()
    seen_at_kill = max(_seqs(sub, "a"))
    spawn(endpoints, "proxy")  # same endpoints; the old ipc socket files are still there

    # Neither client was restarted, yet messages sent after the restart arrive again.
    wait_until(lambda: len([s for s in _seqs(sub, "a") if s > seen_at_kill]) >= 100, 20,
               message="messages after the proxy restart")
    assert sub.alive() and pub.alive()
    after = [s for s in _seqs(sub, "a") if s > seen_at_kill]
    assert after == sorted(after) and len(set(after)) == len(after)


@pytest.mark.slow
def test_10000_reliable_messages_survive_two_proxy_kills_exactly_once(
    run_dir: object, spawn: Spawn, endpoints: BusEndpoints,
) -> None:
    count = 10_000
    # The sender sends at most as far as the gate the test sets, so every kill lands in
    # mid-stream however slow this machine is (a rate alone let a loaded run finish, or
    # come within the last 200 messages, before the kill meant to interrupt it).
    marks, gates = (2500, 6000), (3000, 7000, count)
    proxy = spawn(endpoints, "proxy")
    receiver = spawn(endpoints, "rrecv")
    sender = spawn(endpoints, "rsend", str(count), "4000", str(gates[0]))

    def handled() -> list[str]:
        return [line.split()[1] for line in list(receiver.lines[1:])]

    spawned = time.monotonic()
    for mark, gate in zip(marks, gates[1:], strict=True):
        wait_until(lambda mark=mark: len(handled()) >= mark, 30, message=f"{mark} handled")
        proxy.kill()
        killed = time.monotonic()
        down = len(handled())
        assert down < gate - 200, "the gate let the sender past the kill's mark"
        sender.tell(f"upto {gate}")  # messages sent while the proxy is down
        if endpoints.direct:  # messages and acks go past the proxy: they flow without one
            try:
                wait_until(lambda down=down: len(handled()) >= down + 200, 30,
                           message="messages handled while the proxy is down")
            except WaitTimeout as exc:  # what the two ends said, for the next look
                for peer in (sender, receiver):
                    peer.stop()
                raise AssertionError(
                    f"{exc}; kill at mark {mark}, {killed - spawned:.2f} s after the proxy "
                    f"was started; handled {down} then {len(handled())}; sender said "
                    f"{sender.lines[1:]} {sender.stderr()[-3000:]!r}; receiver said "
                    f"{receiver.stderr()[-3000:]!r}") from exc
        proxy = spawn(endpoints, "proxy")
        spawned = time.monotonic()

    wait_until(lambda: sender.lines[1:] != [], 60, message="the sender to finish")
    assert sender.lines[1] == f"acked {count}"
    wait_until(lambda: len(sender.lines) > 2, 10, message="resend count")
    if not endpoints.direct:
        assert int(sender.lines[2].split()[1]) > 0, "the kills should have cost messages"
    # Acked means handled; the receiver's report of it (its stdout) may still be on the
    # way to us: wait for every line, then judge what arrived.
    wait_until(lambda: len(handled()) >= count, 30, message="the receiver's report of all")
    uuids = handled()
    duplicates = [u for u, n in Counter(uuids).items() if n > 1]
    assert duplicates == []
    assert uuids == [f"a{n}" for n in range(count)]  # every one, once, in order
