"""Holding the CPUs awake: a PM QoS request for the system's lifetime (opt-in).

On an idle machine most of a message's way is waking threads: a CPU that halted takes
tens to hundreds of microseconds to come back, longer in a virtual machine. Linux lets a
process ask that CPUs wake within N µs by writing N to `/dev/cpu_dma_latency` and keeping
the file open: the idle governor then avoids the deeper idle states (with 0, idle CPUs
poll instead of halting). The request ends when the file is closed, by us or by the
kernel when the process dies, so it cannot outlive the system.

`[supervisor] cpu_latency_us` makes the root supervisor hold such a request while it
runs. It costs power (and, in a virtual machine, host CPU): a deployment choice, off by
default. Without write access to the file (root, or a udev rule granting it) the request
is skipped with a warning, as `realtime` is.
"""

from __future__ import annotations

import contextlib
import logging
import os
import struct
from collections.abc import Iterator

PM_QOS_FILE = "/dev/cpu_dma_latency"

log = logging.getLogger("mrss.supervise")


@contextlib.contextmanager
def cpu_latency(microseconds: int | None, path: str = PM_QOS_FILE) -> Iterator[bool]:
    """Hold a request that CPUs wake within `microseconds` (None: no request) for the
    `with` block; yields whether the request is held."""
    if microseconds is None:
        yield False
        return
    try:
        fd = os.open(path, os.O_WRONLY)
    except OSError as exc:
        log.warning("cpu_latency_us %d not applied: cannot open %s: %s (it needs write "
                    "access: root, or a udev rule)", microseconds, path, exc.strerror)
        yield False
        return
    try:
        os.write(fd, struct.pack("i", microseconds))
        log.info("CPUs held to wake within %d us (%s) while the system runs",
                 microseconds, path)
        yield True
    finally:
        os.close(fd)
