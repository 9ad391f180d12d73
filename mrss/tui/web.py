"""The dashboard in a browser: `mrss tui PROJECT --web` (textual-serve).

The web console serves the very same dashboard: each browser that connects gets its own
`mrss tui PROJECT` process (textual-serve's app service), which shows the login screen
first when the project has users (mrss/tui/login.py), so a browser is authenticated
with the same identities as a terminal. Rules:
- loopback (127.0.0.1) by default; another `--host` only for a project with users
  (`mrss users`), else refused with the reason;
- TLS with `--tls-cert FILE --tls-key FILE` (PEM): https and wss; without it beyond
  loopback, a warning says that passwords cross the network in clear;
- `MRSS_OPERATOR_TOKEN` of the server's environment is never passed to a browser's
  dashboard: each browser logs in.
"""

from __future__ import annotations

import asyncio
import os
import signal
import ssl
from pathlib import Path

from aiohttp import web
from textual_serve.server import Server

from mrss.edge.http_token import is_loopback
from mrss.tui.login import TOKEN_ENV


class WebProblem(ValueError):
    """A web console that must not start; the text says why and what to do."""


def exposure_problem(host: str, has_users: bool) -> str:
    """Why serving the console on `host` is refused ("" when it is not)."""
    if is_loopback(host) or has_users:
        return ""
    return (f"--host {host} is not a loopback address and the project has no users: "
            "anyone on the network could steer the mission; add operators with "
            "mrss users PROJECT add NAME --role ROLE, or serve on 127.0.0.1")


def tls_context(cert: Path | None, key: Path | None) -> ssl.SSLContext | None:
    """The server's TLS context (None without a certificate); WebProblem if unusable."""
    if cert is None and key is None:
        return None
    if cert is None or key is None:
        raise WebProblem("TLS needs both --tls-cert and --tls-key")
    context = ssl.create_default_context(ssl.Purpose.CLIENT_AUTH)
    try:
        context.load_cert_chain(cert, key)
    except (OSError, ssl.SSLError) as exc:
        raise WebProblem(f"cannot load the TLS certificate {cert} / key {key}: {exc}") \
            from None
    return context


class WebConsole(Server):
    """textual-serve's server, with TLS and without the operator token of its own
    environment."""

    def __init__(self, command: str, *, host: str, port: int, title: str,
                 tls: ssl.SSLContext | None = None) -> None:
        scheme = "https" if tls is not None else "http"
        shown = f"[{host}]" if ":" in host else host
        super().__init__(command, host=host, port=port, title=title,
                         public_url=f"{scheme}://{shown}:{port}")
        self.tls = tls

    def serve(self, debug: bool = False) -> None:
        """Serve until SIGINT or SIGTERM."""
        os.environ.pop(TOKEN_ENV, None)  # each browser logs in
        self.debug = debug
        self.initialize_logging()
        loop = asyncio.new_event_loop()
        asyncio.set_event_loop(loop)
        loop.add_signal_handler(signal.SIGINT, self.request_exit)
        loop.add_signal_handler(signal.SIGTERM, self.request_exit)
        web.run_app(self._make_app(), host=self.host, port=self.port, handle_signals=False,
                    loop=loop, ssl_context=self.tls, print=lambda *args: None)
