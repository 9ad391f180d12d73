"""One node's bus proxy for `mrss bench nodes`, as its own OS process.

    python -m mrss.bench.node_peer ENDPOINTS_JSON MESH_JSON

Runs `mrss.bus.mesh.MeshThread`, prints "ready", and runs until SIGTERM or stdin closes.
"""

from __future__ import annotations

import json
import signal
import sys
import threading

from mrss.bus import BusEndpoints
from mrss.bus.mesh import MeshSettings, MeshThread


def main(argv: list[str]) -> int:
    endpoints = BusEndpoints.from_dict(json.loads(argv[0]))
    mesh = MeshThread(endpoints, MeshSettings.from_dict(json.loads(argv[1]))).start()
    done = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: done.set())

    def until_eof() -> None:
        sys.stdin.read()
        done.set()

    threading.Thread(target=until_eof, daemon=True).start()
    print("ready", flush=True)
    done.wait()
    mesh.stop()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
