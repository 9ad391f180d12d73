"""The resource broker on its own: grants, waits, pre-emption marks, interruption."""

from __future__ import annotations

import threading

import pytest

from mrss.actors.rcl.resources import Holder, ResourceBroker
from mrss.api import SkillInterrupted
from mrss.errors import ActionError
from mrss.testing import wait_until


class Calls:
    def __init__(self) -> None:
        self.preempted: list[tuple[str, str]] = []
        self.resumed: list[tuple[str, str]] = []

    def broker(self) -> ResourceBroker:
        return ResourceBroker(lambda u, r: self.preempted.append((u, r)),
                              lambda u, r: self.resumed.append((u, r)))


def _acquire_in_thread(broker: ResourceBroker, holder: Holder, interrupt: threading.Event,
                       timeout: float | None = None) -> tuple[threading.Thread, list[object]]:
    result: list[object] = []

    def go() -> None:
        try:
            broker.acquire("r", holder, interrupt, timeout)
            result.append("granted")
        except Exception as exc:
            result.append(exc)

    thread = threading.Thread(target=go, daemon=True)
    thread.start()
    return thread, result


def test_free_resource_is_granted_and_shared_within_an_action() -> None:
    broker = Calls().broker()
    never = threading.Event()
    broker.acquire("r", Holder("a/1/0", "a", 1), never)
    broker.acquire("r", Holder("a/1/1", "a", 1), never)
    assert broker.holders("r") == {"a"}
    broker.release("r", "a/1/0")
    assert broker.holders("r") == {"a"}
    broker.release_token("a/1/1")
    assert broker.holders("r") == set()


def test_higher_priority_preempts_once_and_resumes_the_victim_when_free() -> None:
    calls = Calls()
    broker = calls.broker()
    never = threading.Event()
    broker.acquire("r", Holder("low/1/0", "low", 1), never)
    thread, result = _acquire_in_thread(broker, Holder("high/1/0", "high", 5), never)
    wait_until(lambda: calls.preempted == [("low", "r")])
    assert broker.waiting("r") == ["high"] and result == []
    broker.release_token("low/1/0")  # the victim's skill lets go
    thread.join(5)
    assert result == ["granted"] and broker.holders("r") == {"high"}
    assert calls.resumed == []
    broker.release("r", "high/1/0")
    assert calls.resumed == [("low", "r")]


def test_interrupt_while_waiting_raises_and_frees_the_queue() -> None:
    calls = Calls()
    broker = calls.broker()
    broker.acquire("r", Holder("a/1/0", "a", 3), threading.Event())
    interrupt = threading.Event()
    thread, result = _acquire_in_thread(broker, Holder("b/1/0", "b", 3), interrupt)
    wait_until(lambda: broker.waiting("r") == ["b"])
    interrupt.set()
    broker.wake("b/1/0")
    thread.join(5)
    assert len(result) == 1 and isinstance(result[0], SkillInterrupted)
    assert broker.waiting("r") == [] and calls.preempted == []


def test_acquire_timeout_raises_action_error() -> None:
    broker = Calls().broker()
    broker.acquire("r", Holder("a/1/0", "a", 3), threading.Event())
    with pytest.raises(ActionError, match="not granted within"):
        broker.acquire("r", Holder("b/1/0", "b", 1), threading.Event(), timeout=0.05)
    assert broker.waiting("r") == []


def test_forgetting_an_action_drops_its_preemption_mark() -> None:
    calls = Calls()
    broker = calls.broker()
    never = threading.Event()
    broker.acquire("r", Holder("low/1/0", "low", 1), never)
    thread, result = _acquire_in_thread(broker, Holder("high/1/0", "high", 5), never)
    wait_until(lambda: calls.preempted == [("low", "r")])
    broker.forget_action("low")  # cancelled while pre-empted
    thread.join(5)
    broker.forget_action("high")
    assert result == ["granted"] and calls.resumed == []


def test_a_waiting_acquire_says_behind_whom_it_waits_and_nothing_when_granted() -> None:
    """What the dashboard shows as "queued for R behind X": the holder, then those ahead."""
    import threading

    from mrss.actors.rcl.resources import Holder, ResourceBroker

    broker = ResourceBroker(preempt=lambda *_: None, resume=lambda *_: None)
    told: list[tuple[str, list[str]]] = []
    broker.acquire("arm", Holder("a/0/0", "a", 1), threading.Event(),
                   on_wait=lambda behind: told.append(("a", behind)))
    assert told == []  # granted at once: no wait to tell
    waiters = []
    for uuid in ("b", "c"):
        t = threading.Thread(target=broker.acquire, args=(
            "arm", Holder(f"{uuid}/0/0", uuid, 1), threading.Event()),
            kwargs={"on_wait": lambda behind, u=uuid: told.append((u, behind))})
        t.start()
        waiters.append(t)
        from mrss.testing import wait_until
        wait_until(lambda u=uuid: any(w == u for w, _ in told), timeout=10)
    assert told == [("b", ["a"]), ("c", ["a", "b"])]
    broker.release("arm", "a/0/0")
    broker.release_token("b/0/0")  # b got it and gives it back: c gets it
    for t in waiters:
        t.join(timeout=10)
        assert not t.is_alive()
