"""Who may call the world model's HTTP API: the project's token, or an operator's
identity for what their role allows (reads for every role, writes `WORLD_WRITE`).

`admission` is the one place the rule is applied; the request handler answers with the
status it gives (0: admitted; 401 for no or a wrong token or an unknown, expired
identity; 403 for a known operator whose role may not).
"""

from __future__ import annotations

from http import HTTPStatus

from mrss.auth.roles import CommandKind
from mrss.edge.http_token import authorized
from mrss.runtime.operator_guard import OperatorGuard

READS = frozenset({"GET", "HEAD"})


def admission(header: str | None, method: str, path: str, client: str,
              token: str | None, operators: OperatorGuard | None) -> tuple[int, str]:
    """(0, "") when the request may be served, else (status, why)."""
    if authorized(header, token):
        return 0, ""
    scheme, _, bearer = (header or "").strip().partition(" ")
    if operators is None or not operators.active or scheme.lower() != "bearer":
        return HTTPStatus.UNAUTHORIZED, "no valid token"
    kind = CommandKind.READ if method in READS else CommandKind.WORLD_WRITE
    verdict = operators.check(bearer.strip(), kind, f"{method} {path}", sender=client)
    if verdict.ok:
        return 0, ""
    if "may not" in verdict.reason:
        return HTTPStatus.FORBIDDEN, verdict.reason
    return HTTPStatus.UNAUTHORIZED, verdict.reason
