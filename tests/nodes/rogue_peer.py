"""A peer that must be refused, run in its own network namespace by test_netns.py.

`python rogue_peer.py ENDPOINT SERVER_PUBLIC KEYS_DIR NODE`: connects to a node's inbox
as a CURVE client with the keypair of NODE in KEYS_DIR (a key the project does not
know) and keeps publishing a percept; also opens raw TCP connections that send garbage
instead of the ZeroMQ handshake. Prints `ready`, runs until killed.
"""

from __future__ import annotations

import socket
import sys
import time
from pathlib import Path

import zmq

from mrss.bus.curve import load_keys
from mrss.messages import Percept, encode


def main() -> None:
    endpoint, server_public, keys_dir, node = sys.argv[1:5]
    keys = load_keys(Path(keys_dir), node)
    ctx = zmq.Context()
    pub = ctx.socket(zmq.PUB)
    pub.setsockopt(zmq.LINGER, 0)
    pub.setsockopt(zmq.CURVE_PUBLICKEY, keys.public)
    pub.setsockopt(zmq.CURVE_SECRETKEY, keys.secret)
    pub.setsockopt(zmq.CURVE_SERVERKEY, server_public.encode())
    pub.connect(endpoint)
    host, port = endpoint[len("tcp://"):].rsplit(":", 1)
    print("ready", flush=True)
    while True:
        pub.send_multipart(list(encode(Percept(literal="rogue(here)"), src="rogue")))
        try:
            with socket.create_connection((host, int(port)), timeout=1.0) as raw:
                raw.sendall(b"GET / HTTP/1.0\r\n\r\n" + bytes(range(256)))
        except OSError:
            pass
        time.sleep(0.2)  # a pace, not a synchronisation: it runs until killed


if __name__ == "__main__":
    main()
