"""Where MRSS finds the outside programs it runs (the embedded broker's Mosquitto, the
tests' and benchmarks' private one): one rule, used by components and tests alike."""

from __future__ import annotations

import os
import shutil

#: Where Debian and a local build install Mosquitto (not on a user's PATH: sbin).
MOSQUITTO_PLACES = ("/usr/sbin/mosquitto", "/usr/local/sbin/mosquitto")


def find_mosquitto() -> str | None:
    """The mosquitto binary: on PATH, or where Debian or a local build installs it."""
    found = shutil.which("mosquitto")
    if found:
        return found
    for candidate in MOSQUITTO_PLACES:
        if os.access(candidate, os.X_OK):
            return candidate
    return None
