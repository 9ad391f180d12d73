"""The dashboard's bus link reads on the app's event loop: no thread, nothing lost.

Against a real proxy (a thread of the test process) and real ZeroMQ sockets.
"""

from __future__ import annotations

import asyncio
import threading

from mrss.bus import BusEndpoints, Publisher
from mrss.messages import Envelope, RobotData
from mrss.tui.buslink import BATCH, BusLink

TIMEOUT = 10.0


async def _until(condition: object, what: str) -> None:
    deadline = asyncio.get_running_loop().time() + TIMEOUT
    while not condition():  # type: ignore[operator]
        assert asyncio.get_running_loop().time() < deadline, f"timed out waiting for {what}"
        await asyncio.sleep(0.01)


def test_the_link_reads_a_burst_on_the_loop_whole_and_in_order_without_a_thread(
        endpoints: BusEndpoints) -> None:
    count = 2 * BATCH + 500  # more than one turn of the loop takes

    async def main() -> list[Envelope]:
        link = BusLink(endpoints, prefixes=("robot.",))
        wakes: list[int] = []
        before = set(threading.enumerate())  # other tests' threads may live on in here
        link.start(wake=lambda: wakes.append(1))
        try:
            await _until(lambda: link.connected, "the proxy's greeting")
            assert not [t for t in set(threading.enumerate()) - before
                        if t.name.startswith("mrss-sub-")]
            got: list[Envelope] = []
            with Publisher(endpoints, src="feeder") as pub:
                for n in range(count):
                    pub.publish(RobotData(robot="b", data={"n": n}))

                def arrived() -> bool:
                    got.extend(link.drain())
                    return len(got) >= count
                await _until(arrived, f"{count} messages")
            assert wakes  # the app was told, not left to find them
            return got
        finally:
            link.close()

    got = asyncio.run(main())
    assert [env.body.data["n"] for env in got] == list(range(count))  # type: ignore[union-attr]


def test_a_closed_link_takes_nothing_more_and_closing_twice_is_harmless(
        endpoints: BusEndpoints) -> None:
    async def main() -> int:
        link = BusLink(endpoints, prefixes=("robot.",))
        link.start(wake=lambda: None)
        await _until(lambda: link.connected, "the proxy's greeting")
        link.close()
        with Publisher(endpoints, src="feeder") as pub:
            pub.publish(RobotData(robot="b", data={"n": 1}))
            pub.flush()
        link.poll()
        link.close()
        return link.received

    assert asyncio.run(main()) == 0


def test_a_steady_stream_is_read_in_batches_a_read_every_so_often_not_per_message(
        endpoints: BusEndpoints) -> None:
    """After a read the socket is not watched for READ_EVERY: a message every few
    milliseconds makes a few reads, not one each (each was a wake of the loop), and
    nothing is lost or reordered, with the app draining now and then meanwhile."""
    count = 60

    async def main() -> tuple[list[Envelope], int]:
        link = BusLink(endpoints, prefixes=("robot.",))
        link.start(wake=lambda: None)
        sub = link._sub
        assert sub is not None
        reads: list[int] = []
        take_ready = sub.take_ready

        def counting(limit: int = BATCH) -> list[Envelope]:
            got = take_ready(limit)
            reads.extend([len(got)] if got else [])
            return got

        sub.take_ready = counting  # type: ignore[method-assign]
        try:
            await _until(lambda: link.connected, "the proxy's greeting")
            got: list[Envelope] = []
            with Publisher(endpoints, src="feeder") as pub:
                for n in range(count):
                    pub.publish(RobotData(robot="b", data={"n": n}))
                    pub.flush()
                    await asyncio.sleep(0.005)  # pacing the stream, not synchronisation
                    if n % 20 == 19:
                        got.extend(link.drain())

                def arrived() -> bool:
                    got.extend(link.drain())
                    return len(got) >= count
                await _until(arrived, f"{count} messages")
            return got, len([r for r in reads if r])
        finally:
            link.close()

    got, reads = asyncio.run(main())
    assert [env.body.data["n"] for env in got] == list(range(count))  # type: ignore[union-attr]
    # 60 messages over >= 0.3 s: a read each 0.1 s and one per drain; per message was 60
    assert reads <= 20, reads
