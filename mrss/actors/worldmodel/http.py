"""A small HTTP JSON API over the world model, for user interfaces (loopback by default).

    GET  /objects?kind=hotspot   -> 200 {"objects": [...]}
    GET  /objects?lat=..&lon=..&radius_m=..[&kind=..]  -> nearest first, with distance_m
    GET  /objects/<id>           -> 200 {...} | 404
    POST /objects  {id, kind, position?, attributes?}
                                 -> 201 {"op": "insert", "object": {...}} | 200 on update
Every answer is JSON, errors `{"error": "..."}`: 400 (bad input, a body that is not
JSON or not Unicode text, a malformed request line or header, a request without an
HTTP/1.x version, HTTP/0.9, a Content-Length that is not digits, Content-Length values
that disagree or come with Transfer-Encoding: RFC 9112 6.3), 401 (no or wrong bearer token),
404 (no such object or path), 405 (method), 408 (the request did not arrive within the
connection timeout), 411/413 (body length), 414 (request line over 64 KiB), 431 (a
header line too long or too many headers), 501 (unknown method), 505 (HTTP/2 and up).
Errors raised while reading the request close the connection.

With a `token` (`mrss.edge.http_token`) every request must carry ``Authorization:
Bearer <token>``, or an operator's identity for what the role allows (403 otherwise:
`http_admission`, with the project's operators). Each connection is served on its own
thread with a socket timeout (`timeout`, 10 s): a client that stalls mid-request is
answered 408 and dropped, and never delays another. The server goes through the same
`ObjectService` as the bus, so rules fire for HTTP writes too.

Refused requests (`REFUSED`: no valid token, bad input, a malformed request) are counted
by (client address, status) in a `RejectionLog` ("HTTP request"), logged once per
interval and reported with the component's other refusals (docs/edges.md); a flood of
them is a few log lines, not one per request.

One idea in one module: the conversation with one client (read, admit, route, answer),
which the standard library's request handler keeps in one class.
"""

from __future__ import annotations

import json
import logging
import re
import socket
import threading
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any, Protocol
from urllib.parse import parse_qs, unquote, urlsplit

from mrss.actors.worldmodel.http_admission import admission
from mrss.actors.worldmodel.store import Change, Position, WorldObject, WorldStoreUnavailable
from mrss.edge.payloads import PayloadError, decode_json
from mrss.edge.rejections import RejectionLog
from mrss.runtime.operator_guard import OperatorGuard

log = logging.getLogger("mrss.worldmodel.http")
MAX_BODY = 1 << 20
MAX_REQUEST_LINE = 65536
DEFAULT_TIMEOUT = 10.0
#: The answers that refuse a client's request (counted and logged at a limited rate).
REFUSED = frozenset({400, 401, 405, 411, 413, 414, 431, 501, 505})
HTTP_VERSION = re.compile(r"HTTP/(\d+)\.(\d+)")  # HTTP/1.1; RFC 9112: one digit each


class ObjectService(Protocol):
    """What the HTTP API needs from the world model."""

    def get(self, object_id: str) -> WorldObject | None: ...

    def objects(self, kind: str | None = None) -> list[WorldObject]: ...

    def upsert(self, obj: WorldObject) -> Change: ...

    def near(self, position: Position, radius_m: float,
             kind: str | None = None) -> list[tuple[WorldObject, float]]: ...


class _HttpError(Exception):
    def __init__(self, status: int, message: str) -> None:
        super().__init__(message)
        self.status = status
        self.message = message


class _Handler(BaseHTTPRequestHandler):
    server: _Server
    protocol_version = "HTTP/1.1"
    # Errors found before the version is read still get a status line and headers (the
    # stdlib's default, HTTP/0.9, would answer them with a bare body).
    default_request_version = "HTTP/1.1"
    # Headers and body leave in two writes: without TCP_NODELAY the body of an answer on
    # a kept-alive connection waits for the client's delayed ACK (~40 ms).
    disable_nagle_algorithm = True

    def setup(self) -> None:
        super().setup()
        self.connection.settimeout(self.server.timeout_s)  # per connection: reads, writes

    def log_message(self, format: str, *args: Any) -> None:  # noqa: A002 (stdlib name)
        log.debug("%s " + format, self.address_string(), *args)

    def _reply(self, status: int, body: Any, *, close: bool = False) -> None:
        data = json.dumps(body, allow_nan=False).encode()
        self.send_response(status)
        self.send_header("Content-Type", "application/json")
        self.send_header("Content-Length", str(len(data)))
        if status == HTTPStatus.UNAUTHORIZED:
            self.send_header("WWW-Authenticate", 'Bearer realm="mrss-worldmodel"')
        if close:
            self.close_connection = True
            self.send_header("Connection", "close")
        self.end_headers()
        self.wfile.write(data)

    def send_error(self, code: int, message: str | None = None,
                   explain: str | None = None) -> None:
        """Every error the stdlib raises before dispatch, as the API's JSON error."""
        try:
            short = self.responses[code][0]
        except KeyError:
            short = "error"
        text = message or short
        if explain and explain != text:
            text = f"{text}: {explain}"
        self._refused(code, text)
        self._reply(code, {"error": text}, close=True)

    def _refused(self, code: int, detail: str) -> None:
        """Count (and log, at a limited rate) a refused request."""
        if code in REFUSED:
            try:
                short = self.responses[code][0]
            except KeyError:
                short = "error"
            self.server.rejections.reject(str(self.client_address[0]), f"{code} {short}",
                                          detail)
        else:
            log.debug("world model HTTP %d from %s: %s", code, self.address_string(), detail)

    def parse_request(self) -> bool:
        """The stdlib's parse, with HTTP/0.9 refused before any header is read (its
        client sends none and waits) and the body's length settled (`_body_length`)."""
        line = str(self.raw_requestline, "iso-8859-1").rstrip("\r\n")
        problem = _version_problem(line.split())
        if problem:
            self.requestline, self.request_version = line, "HTTP/1.1"
            self.command = line.split()[0] if line.split() else ""
            self.send_error(HTTPStatus.BAD_REQUEST, problem)
            return False
        if not super().parse_request():
            return False
        problem = self._length_problem()
        if problem:
            self.send_error(HTTPStatus.BAD_REQUEST, problem)
            return False
        return True

    def _length_problem(self) -> str:
        """Why the body's length is ambiguous (RFC 9112 6.3), or ""; sets `_body_length`
        (None: no Content-Length)."""
        self._body_length: int | None = None
        values = [v.strip() for field in self.headers.get_all("Content-Length") or []
                  for v in field.split(",")]
        if not values:
            return ""
        if not all(v.isascii() and v.isdigit() for v in values):
            return f"bad Content-Length {', '.join(values)[:80]!r}: digits only"
        if len({int(v) for v in values}) > 1:
            return f"conflicting Content-Length values {', '.join(values)[:80]!r}"
        if "Transfer-Encoding" in self.headers:
            return "Content-Length and Transfer-Encoding together"
        self._body_length = int(values[0])
        return ""

    def handle_one_request(self) -> None:
        """One request; a read that times out is answered 408 and ends the connection."""
        self._answered = False
        try:
            self.raw_requestline = self.rfile.readline(MAX_REQUEST_LINE + 1)
            if len(self.raw_requestline) > MAX_REQUEST_LINE:
                self.requestline, self.request_version, self.command = "", "HTTP/1.1", ""
                self.send_error(HTTPStatus.REQUEST_URI_TOO_LONG,
                                f"request line over {MAX_REQUEST_LINE} bytes")
                return
            if not self.raw_requestline.endswith(b"\n"):
                self.close_connection = True  # the client left mid-line (or sent nothing)
                return
            if not self.parse_request():
                return
            method = getattr(self, "do_" + self.command, None)
            if method is None:
                self.send_error(HTTPStatus.NOT_IMPLEMENTED,
                                f"unsupported method {self.command[:40]!r}; use GET or POST")
                return
            method()
            self.wfile.flush()
        except ConnectionError:
            self.close_connection = True  # the client went away: nothing to answer
        except TimeoutError:
            self.close_connection = True
            if self._answered:
                return
            log.info("world model HTTP: %s sent no complete request within %.1f s; dropped",
                     self.address_string(), self.server.timeout_s)
            try:
                self.request_version = "HTTP/1.1"
                self._headers_buffer: list[bytes] = []
                self.send_error(HTTPStatus.REQUEST_TIMEOUT,
                                f"no complete request within {self.server.timeout_s:g} s")
                self.wfile.flush()
            except OSError:
                pass

    def handle_expect_100(self) -> bool:
        """`Expect: 100-continue`: a request without the token is refused before its body."""
        if not self._admitted(self.command or "?"):
            return False
        return bool(super().handle_expect_100())

    def _refuse_unauthorized(self, method: str) -> None:
        self._refused(HTTPStatus.UNAUTHORIZED,
                      f"{method} {urlsplit(self.path).path[:80]} without a valid token")
        self._reply(HTTPStatus.UNAUTHORIZED, {
            "error": "missing or wrong token: send 'Authorization: Bearer <token>' "
                     "(the [worldmodel] token of the project)"}, close=True)

    def end_headers(self) -> None:
        self._answered = True
        super().end_headers()

    def _admitted(self, method: str) -> bool:
        """Whether the request may be served (`http_admission`); else it is answered."""
        status, why = admission(self.headers.get("Authorization"), method,
                                urlsplit(self.path).path[:80], self.client_address[0],
                                self.server.token, self.server.operators)
        if status == HTTPStatus.FORBIDDEN:
            self._reply(status, {"error": why}, close=True)
        elif status:
            self._refuse_unauthorized(method)
        return not status

    def _dispatch(self, method: str) -> None:
        if not self._admitted(method):
            return
        self._body_read = False
        try:
            status, body = self._route(method)
        except _HttpError as exc:
            status, body = exc.status, {"error": exc.message}
            self._refused(status, f"{method} {urlsplit(self.path).path[:80]}: {exc.message}")
        except TimeoutError:
            raise  # the body did not arrive in time: answered 408 by handle_one_request
        except WorldStoreUnavailable as exc:  # the database is down: no bug, no traceback
            log.warning("world model HTTP %s %s: %s", method, urlsplit(self.path).path[:80],
                        exc)
            status, body = 503, {"error": f"WorldStoreUnavailable: {exc}"}
        except Exception as exc:  # keep serving whatever the service did
            log.exception("world model HTTP %s %s failed", method, self.path)
            status, body = 500, {"error": f"internal error: {exc.__class__.__name__}"}
        has_body = bool(self._body_length) or "Transfer-Encoding" in self.headers
        unread = has_body and not self._body_read
        self._reply(status, body, close=unread)  # an unread body would be the next request

    def _route(self, method: str) -> tuple[int, Any]:
        parts = urlsplit(self.path)
        segments = [unquote(s) for s in parts.path.strip("/").split("/")]
        if not segments or segments[0] != "objects" or len(segments) > 2:
            raise _HttpError(404, f"no such path {parts.path!r}; use /objects")
        service = self.server.service
        if len(segments) == 2:
            if method != "GET":
                raise _HttpError(405, f"{method} not allowed on /objects/<id>")
            obj = service.get(segments[1])
            if obj is None:
                raise _HttpError(404, f"no object with id {segments[1]!r}")
            return 200, obj.to_json()
        if method == "GET":
            return 200, {"objects": self._list(service, parse_qs(parts.query))}
        if method == "POST":
            try:
                obj = WorldObject.from_json(self._json_body())
            except ValueError as exc:
                raise _HttpError(400, f"bad object: {exc}") from None
            change = service.upsert(obj)
            return (201 if change.op == "insert" else 200), {
                "op": change.op, "object": change.obj.to_json()}
        raise _HttpError(405, f"{method} not allowed on /objects")

    @staticmethod
    def _list(service: ObjectService, query: dict[str, list[str]]) -> list[Any]:
        unknown = set(query) - {"kind", "lat", "lon", "radius_m"}
        if unknown:
            raise _HttpError(400, f"unknown query parameter(s) {sorted(unknown)}")
        if any(len(v) > 1 for v in query.values()):
            raise _HttpError(400, "give each query parameter at most once")
        kind = query["kind"][0] if "kind" in query else None
        near = [query[k][0] for k in ("lat", "lon", "radius_m") if k in query]
        if not near:
            return [o.to_json() for o in service.objects(kind)]
        if len(near) != 3:
            raise _HttpError(400, "lat, lon and radius_m go together")
        try:
            lat, lon, radius = (float(v) for v in near)
            position = Position(lat, lon)
            if not radius >= 0:
                raise ValueError("radius_m must be a non-negative number")
        except ValueError as exc:
            raise _HttpError(400, f"bad position query: {exc}") from None
        return [{**o.to_json(), "distance_m": d} for o, d in service.near(position, radius,
                                                                          kind)]

    def _json_body(self) -> Any:
        length = self._body_length  # digits, and one value (parse_request)
        if length is None:
            raise _HttpError(411, "Content-Length required")
        if length > MAX_BODY:
            self.close_connection = True
            raise _HttpError(413, f"body must be at most {MAX_BODY} bytes")
        raw = self.rfile.read(length)
        self._body_read = True
        try:  # the edge's one JSON door: not UTF-8, not JSON, a lone surrogate, NaN
            return decode_json(raw)
        except PayloadError as exc:
            raise _HttpError(400, f"body {exc.reason.removeprefix('payload ')}") from None

    def do_GET(self) -> None:  # noqa: N802 (stdlib naming)
        self._dispatch("GET")

    def do_POST(self) -> None:  # noqa: N802
        self._dispatch("POST")

    def do_PUT(self) -> None:  # noqa: N802
        self._dispatch("PUT")

    def do_DELETE(self) -> None:  # noqa: N802
        self._dispatch("DELETE")


def _version_problem(words: list[str]) -> str:
    """Why a request line's HTTP version is refused with 400 (RFC 9112 2.3), or "".
    HTTP/2 and up are left to the stdlib (505); other malformed lines too (400)."""
    if len(words) == 2:  # "GET /path": HTTP/0.9, which has no version and no headers
        return f"request line must be METHOD PATH HTTP/1.x, not {' '.join(words)[:80]!r}"
    if len(words) != 3 or not words[2].startswith("HTTP/"):
        return ""
    match = HTTP_VERSION.fullmatch(words[2])
    if match is not None and int(match[1]) >= 2:
        return ""
    if match is None or len(match[1]) != 1 or len(match[2]) != 1 or match[1] == "0":
        return (f"Bad request version {words[2][:20]!r}: HTTP/1.0 or HTTP/1.1 "
                "(HTTP/0.9 is not served)")
    return ""


class _Server(ThreadingHTTPServer):
    daemon_threads = True

    def handle_error(self, request: Any, client_address: Any) -> None:
        """One line, never a traceback on stderr: a client's bad luck is not ours."""
        log.warning("world model HTTP: connection from %s failed", client_address,
                    exc_info=log.isEnabledFor(logging.DEBUG))

    def __init__(self, address: tuple[str, int], service: ObjectService, token: str | None,
                 timeout_s: float, operators: OperatorGuard | None = None) -> None:
        if ":" in address[0]:
            self.address_family = socket.AF_INET6
        super().__init__(address, _Handler)
        self.service = service
        self.token = token
        self.operators = operators  # the project's operators (mrss.runtime.operator_guard)
        self.timeout_s = timeout_s
        self.rejections = RejectionLog(log, "HTTP request")


class WorldModelHttp:
    """The HTTP API, served on a background thread until `stop()`.

    `token`: required as ``Authorization: Bearer <token>`` on every request (None: no
    token). `timeout`: seconds a connection may take to send a request (and to take its
    answer) before it is dropped.
    """

    def __init__(self, service: ObjectService, host: str = "127.0.0.1", port: int = 0, *,
                 token: str | None = None, timeout: float = DEFAULT_TIMEOUT,
                 operators: OperatorGuard | None = None) -> None:
        if timeout <= 0:
            raise ValueError("timeout must be positive")
        self._server = _Server((host, port), service, token, timeout, operators)
        self._thread = threading.Thread(target=self._server.serve_forever, args=(0.05,),
                                        name="worldmodel-http", daemon=True)

    @property
    def token_required(self) -> bool:
        """Whether requests need a bearer token."""
        return self._server.token is not None

    @property
    def url(self) -> str:
        """Base URL, e.g. http://127.0.0.1:8765."""
        address, port = self._server.server_address[:2]
        host = address.decode() if isinstance(address, bytes) else str(address)
        host = f"[{host}]" if ":" in host else host
        return f"http://{host}:{port}"

    def start(self) -> None:
        """Serve on the background thread."""
        self._thread.start()
        log.info("world model HTTP API on %s", self.url)

    @property
    def rejections(self) -> RejectionLog:
        """The refused requests, by (client address, status)."""
        return self._server.rejections

    def stop(self) -> None:
        """Stop serving and close the socket."""
        if self._thread.is_alive():
            self._server.shutdown()
            self._thread.join(timeout=5)
        self._server.server_close()
        self._server.rejections.flush()
