"""A small HTTP JSON API over the world model, for user interfaces (loopback by default).

    GET  /objects?kind=hotspot   -> 200 {"objects": [...]}
    GET  /objects?lat=..&lon=..&radius_m=..[&kind=..]  -> nearest first, with distance_m
    GET  /objects/<id>           -> 200 {...} | 404
    POST /objects  {id, kind, position?, attributes?}
                                 -> 201 {"op": "insert", "object": {...}} | 200 on update
Every error is JSON `{"error": "..."}` with 400 (bad input), 404 (no such object or
path), 405 (method), 411/413 (body length). The server runs on its own thread and
goes through the same `ObjectService` as the bus, so rules fire for HTTP writes too.
"""

from __future__ import annotations

import json
import logging
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any, Protocol
from urllib.parse import parse_qs, unquote, urlsplit

from mrss.edge.worldmodel_store import Change, Position, WorldObject

log = logging.getLogger("mrss.worldmodel.http")
MAX_BODY = 1 << 20


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

    def log_message(self, format: str, *args: Any) -> None:  # noqa: A002 (stdlib name)
        log.debug("%s " + format, self.address_string(), *args)

    def _reply(self, status: int, body: Any) -> None:
        data = json.dumps(body, allow_nan=False).encode()
        self.send_response(status)
        self.send_header("Content-Type", "application/json")
        self.send_header("Content-Length", str(len(data)))
        self.end_headers()
        self.wfile.write(data)

    def _dispatch(self, method: str) -> None:
        try:
            status, body = self._route(method)
        except _HttpError as exc:
            status, body = exc.status, {"error": exc.message}
        except Exception as exc:  # keep serving whatever the service did
            log.exception("world model HTTP %s %s failed", method, self.path)
            status, body = 500, {"error": f"internal error: {exc.__class__.__name__}"}
        self._reply(status, body)

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
        length_text = self.headers.get("Content-Length")
        if length_text is None:
            raise _HttpError(411, "Content-Length required")
        try:
            length = int(length_text)
        except ValueError:
            raise _HttpError(400, "bad Content-Length") from None
        if length < 0 or length > MAX_BODY:
            self.close_connection = True
            raise _HttpError(413, f"body must be at most {MAX_BODY} bytes")
        raw = self.rfile.read(length)
        try:
            return json.loads(raw.decode("utf-8"), parse_constant=_no_constant)
        except (UnicodeDecodeError, ValueError, RecursionError) as exc:
            raise _HttpError(400, f"body is not JSON: {exc}") from None

    def do_GET(self) -> None:  # noqa: N802 (stdlib naming)
        self._dispatch("GET")

    def do_POST(self) -> None:  # noqa: N802
        self._dispatch("POST")

    def do_PUT(self) -> None:  # noqa: N802
        self._dispatch("PUT")

    def do_DELETE(self) -> None:  # noqa: N802
        self._dispatch("DELETE")


def _no_constant(name: str) -> Any:
    raise ValueError(f"{name} is not allowed")


class _Server(ThreadingHTTPServer):
    daemon_threads = True

    def __init__(self, address: tuple[str, int], service: ObjectService) -> None:
        super().__init__(address, _Handler)
        self.service = service


class WorldModelHttp:
    """The HTTP API, served on a background thread until `stop()`."""

    def __init__(self, service: ObjectService, host: str = "127.0.0.1", port: int = 0) -> None:
        self._server = _Server((host, port), service)
        self._thread = threading.Thread(target=self._server.serve_forever, args=(0.05,),
                                        name="worldmodel-http", daemon=True)

    @property
    def url(self) -> str:
        """Base URL, e.g. http://127.0.0.1:8765."""
        host, port = self._server.server_address[:2]
        return f"http://{host!s}:{port}"

    def start(self) -> None:
        """Serve on the background thread."""
        self._thread.start()
        log.info("world model HTTP API on %s", self.url)

    def stop(self) -> None:
        """Stop serving and close the socket."""
        if self._thread.is_alive():
            self._server.shutdown()
            self._thread.join(timeout=5)
        self._server.server_close()
