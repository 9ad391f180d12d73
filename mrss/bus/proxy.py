"""The bus proxy process: `python -m mrss.bus.proxy --frontend EP --backend EP`.

Or `--run-dir DIR` for the default ipc endpoints. It prints one line
`ready {"frontend": ..., "backend": ...}` on stdout once both endpoints are bound, and
exits 0 on SIGTERM or SIGINT, removing its ipc socket files. A proxy killed with SIGKILL
leaves them behind; the next proxy on the same endpoints removes them, unless a live
proxy still answers there (then it exits 1). Clients need not be restarted: ZeroMQ
reconnects them and subscribers re-send their subscriptions.
"""

from __future__ import annotations

import argparse
import json
import signal
import sys
import threading
from collections.abc import Sequence
from types import FrameType

from mrss.bus.endpoints import BusEndpoints
from mrss.bus.forwarder import ProxyThread, run_proxy
from mrss.errors import BusError, ConfigError

__all__ = ["ProxyThread", "main", "run_proxy"]


def main(argv: Sequence[str] | None = None) -> int:
    """`python -m mrss.bus.proxy`: run a proxy process until SIGTERM/SIGINT."""
    parser = argparse.ArgumentParser(prog="python -m mrss.bus.proxy", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--frontend", help="endpoint publishers connect to (XSUB side)")
    parser.add_argument("--backend", help="endpoint subscribers connect to (XPUB side)")
    parser.add_argument("--run-dir", help="use ipc sockets bus-pub.sock/bus-sub.sock here")
    parser.add_argument("--direct", action="store_true",
                        help="deliver directly: introduce publishers to subscribers and "
                        "forward nothing (docs/bus.md, 'Direct delivery')")
    parser.add_argument("--fresh", action="store_true",
                        help="direct: the first proxy on these endpoints (no clients to "
                        "wait for): introduce publishers at once")
    args = parser.parse_args(argv)
    try:
        if args.run_dir and not (args.frontend or args.backend):
            endpoints = BusEndpoints.ipc(args.run_dir, direct=args.direct)
        elif args.frontend and args.backend and not args.run_dir:
            endpoints = BusEndpoints(args.frontend, args.backend, args.direct)
        else:
            parser.error("give either --run-dir, or both --frontend and --backend")
    except ConfigError as exc:
        print(f"mrss bus proxy: {exc}", file=sys.stderr)
        return 2
    stop = threading.Event()

    def on_signal(signum: int, frame: FrameType | None) -> None:
        stop.set()

    signal.signal(signal.SIGTERM, on_signal)
    signal.signal(signal.SIGINT, on_signal)

    def announce() -> None:
        print("ready " + json.dumps(endpoints.to_dict()), flush=True)

    try:
        run_proxy(endpoints, stop=stop, ready=announce, fresh=args.fresh)
    except BusError as exc:
        print(f"mrss bus proxy: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
