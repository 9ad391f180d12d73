"""The ground side of the MAVLink command protocol, used by `MavlinkLink`.

COMMAND_LONG -> COMMAND_ACK. A command is sent again (its confirmation field counting
the attempts) when no ack comes within `timeout`, up to `retries` times; an ack of
MAV_RESULT_IN_PROGRESS starts the wait again, within a budget: a command still in
progress `progress_timeout` seconds after its first IN_PROGRESS raises CommandTimeout (a
vehicle answering IN_PROGRESS for ever, or a forged stream of them, cannot hold the link's
one command slot for ever). ACCEPTED returns; any other result raises
CommandRejected with the result's name and, when the vehicle said why (a warning
STATUSTEXT at most TEXT_REASON_WINDOW_S before the command went out), its words; no ack
at all raises CommandTimeout, and the link going down meanwhile LinkDown.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Sequence

from mrss.links.errors import CommandRejected, CommandTimeout
from mrss.links.mavconn import MAV, enum_name

TEXT_REASON_WINDOW_S = 1.0
DEFAULT_PROGRESS_TIMEOUT_S = 30.0


class _PendingCommand:
    """A COMMAND_LONG waiting for its COMMAND_ACK."""

    def __init__(self, command: int) -> None:
        self.command = command
        self.event = threading.Event()
        self.result: int | None = None


class CommandExchange:
    """The commands of one vehicle awaiting their acks, and its latest warning.

    `send(command, attempt, params)` sends one COMMAND_LONG (7 params); `require_up`
    raises LinkDown while the link is down. The caller runs one command at a time.
    """

    def __init__(self, robot: str, send: Callable[[int, int, list[float]], None],
                 require_up: Callable[[], None]) -> None:
        self.robot = robot
        self._send = send
        self._require_up = require_up
        self._pending: dict[int, _PendingCommand] = {}
        self._pending_lock = threading.Lock()
        self._last_warning: tuple[float, str] | None = None

    def run(self, command: int, params: Sequence[float], timeout: float, retries: int,
            progress_timeout: float = DEFAULT_PROGRESS_TIMEOUT_S) -> int:
        """Send `command` until acknowledged; return the MAV_RESULT if ACCEPTED."""
        name = enum_name("MAV_CMD", command)
        values = [float(p) for p in params] + [0.0] * (7 - len(params))
        for attempt in range(retries):
            self._require_up()
            pending = _PendingCommand(command)
            with self._pending_lock:
                self._pending[command] = pending
            sent_at = time.monotonic()
            self._send(command, attempt, values)
            try:
                result = self._await_ack(pending, timeout, progress_timeout)
            finally:
                with self._pending_lock:
                    self._pending.pop(command, None)
            if result is None:
                continue
            if result == MAV.MAV_RESULT_IN_PROGRESS:  # past its budget: not sent again
                raise CommandTimeout(self.robot, name, progress_timeout, attempt + 1,
                                     "still in progress")
            if result == MAV.MAV_RESULT_ACCEPTED:
                return result
            raise CommandRejected(self.robot, name, self._describe(result, sent_at))
        raise CommandTimeout(self.robot, name, timeout, retries)

    def acked(self, command: int, result: int) -> None:
        """A COMMAND_ACK came (from the receiving thread)."""
        with self._pending_lock:
            pending = self._pending.get(command)
        if pending is not None:
            pending.result = result
            pending.event.set()

    def warned(self, text: str) -> None:
        """The vehicle sent a warning (or worse): the reason of a refusal that follows."""
        self._last_warning = (time.monotonic(), text)

    def _await_ack(self, pending: _PendingCommand, timeout: float,
                   progress_timeout: float) -> int | None:
        deadline = time.monotonic() + timeout
        progress_deadline: float | None = None  # set by the first IN_PROGRESS
        while True:
            remaining = deadline - time.monotonic()
            if pending.event.wait(min(max(remaining, 0.0), 0.1)):
                if pending.result == MAV.MAV_RESULT_IN_PROGRESS:
                    now = time.monotonic()
                    if progress_deadline is None:
                        progress_deadline = now + progress_timeout
                    if now >= progress_deadline:
                        return pending.result
                    pending.event.clear()
                    deadline = min(now + timeout, progress_deadline)
                    continue
                return pending.result
            self._require_up()
            if remaining <= 0:
                if progress_deadline is not None and time.monotonic() >= progress_deadline:
                    return int(MAV.MAV_RESULT_IN_PROGRESS)  # in progress past its budget
                return None

    def _describe(self, result: int, sent_at: float) -> str:
        text = enum_name("MAV_RESULT", result)
        warning = self._last_warning
        if warning is not None and warning[0] >= sent_at - TEXT_REASON_WINDOW_S:
            text += f" ({warning[1]})"
        return text
