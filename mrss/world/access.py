"""Ways for the data layer to reach a world model: over the bus, over HTTP, or in-process.

All three give plain JSON objects (`{"id", "kind", "position", "geometry", "attributes",
...}`) and satisfy `mrss.world.access.WorldModelAccess`; the bus and local ones also ask
the spatial predicates (`intersecting`, `within`, `within_distance`, GeoJSON in). The bus
one talks to the world model component; the HTTP one to any service with the same small
API (a deployment's own world model); the local one
(`mrss.actors.worldmodel.local.LocalWorldModel`) wraps a `WorldModel` in the same process.
"""

from __future__ import annotations

import json
import logging
import threading
import urllib.error
import urllib.request
from pathlib import Path
from typing import Any, Protocol
from urllib.parse import quote, urlencode

from mrss.edge.retry import DependencyUnavailable
from mrss.errors import MrssError
from mrss.runtime.datalayer_client import DataLayerClient, DataLayerError, DataLayerUnavailable
from mrss.world.topics import UNAVAILABLE_PREFIX, WM_REQUEST_TOPIC, wm_reply_topic

WORLD_MODEL_URL_FILE = "worldmodel.url"
log = logging.getLogger("mrss.datalayer")
MAX_BATCH = 200   # writes per `wm.upsert_many` request of the telemetry path
PACE_TIMEOUT_S = 1.0  # a batch's answer waited for this long before the next is sent


class WorldModelUnavailable(DependencyUnavailable):
    """The world model could not be reached, did not answer in time, or failed (HTTP 5xx)."""


class WorldModelRejected(MrssError, ValueError):
    """The world model refused the request (HTTP 4xx): the object or query is wrong."""


class BusWorldModel:
    """The embedded world model component, reached with requests on `dl.request.wm`.

    A call raises DataLayerError with the reason; DataLayerUnavailable (a
    DependencyUnavailable) when no reply came in time or the world model's database is
    down, so callers can tell "try later" from "wrong request"."""

    def __init__(self, bus: Any, timeout: float = 2.0) -> None:
        # the world model answers on a topic of our own (`wm_reply_topic`: our src)
        reply_topic = wm_reply_topic(str(getattr(bus, "src", "")))
        self.client = DataLayerClient(bus, request_topic=WM_REQUEST_TOPIC,
                                      reply_topic=reply_topic, default_timeout=timeout)
        self._queued: list[dict[str, Any]] = []   # writes not waited for, not yet sent
        self._taken = 0   # writes taken off the queue to be sent, ever
        self._wake = threading.Condition()
        self._sending = threading.Lock()   # one batch (or call) at a time, in order
        self._writer: threading.Thread | None = None
        self._closed = False
        self._unsent = False   # the last batch could not be sent (logged once)
        self._paced = True   # the next batch waits for the last one's answer
        self._answers_unpaced = 0   # the client's answered sends when pacing stopped
        self.batches = 0   # requests that carried queued writes

    @property
    def paced(self) -> bool:
        """Whether the next batch waits for the last one's answer (the world model
        answers); False after one went unanswered for PACE_TIMEOUT_S, until answers come."""
        return self._paced

    def close(self) -> None:
        """Send the queued writes, then stop."""
        with self._wake:
            self._closed = True
            self._wake.notify_all()
        if self._writer is not None:
            self._writer.join(timeout=2.0)
        self._flush()
        self.client.close()

    def _call(self, function: str, args: list[Any]) -> Any:
        with self._wake:   # the writes queued before this call go first (not later ones:
            due = self._taken + len(self._queued)   # the call must not wait for ever)
        self._flush(due)
        try:
            return self.client.call(function, args)
        except DataLayerError as exc:
            if not isinstance(exc, DataLayerUnavailable) and \
                    exc.reason.startswith(UNAVAILABLE_PREFIX):
                raise DataLayerUnavailable(function, exc.reason,
                                           request_id=exc.request_id) from None
            raise

    def get(self, object_id: str) -> dict[str, Any] | None:
        result = self._call("wm.get", [object_id])
        return None if result is None else dict(result)

    def objects(self, kind: str | None = None) -> list[dict[str, Any]]:
        return list(self._call("wm.list", [kind]))

    def upsert(self, obj: dict[str, Any]) -> dict[str, Any]:
        return dict(self._call("wm.upsert", [obj]))

    def upsert_nowait(self, obj: dict[str, Any]) -> None:
        """Write without waiting for the answer (in order with this client's requests);
        the data layer's telemetry path, which needs no answer, uses it.

        The write is queued; a writer thread sends what is queued as one
        `wm.upsert_many` request (at most MAX_BATCH objects) and waits for its answer
        before it sends the next, so while one batch is on its way the next records
        gather: one request, one reply and one transaction in the world model per batch
        instead of per record, and the busier the world model the bigger its batches
        (one in flight at a time). Without an answer within PACE_TIMEOUT_S (the world
        model is away or stalled) the writer sends on without waiting until answers
        come again. An invalid object is counted in `client.failed_sends`."""
        with self._wake:
            self._queued.append(obj)
            if self._writer is None and not self._closed:
                self._writer = threading.Thread(target=self._write_queued, daemon=True,
                                                name="wm-writes")
                self._writer.start()
            self._wake.notify()

    def _write_queued(self) -> None:
        while True:
            with self._wake:
                self._wake.wait_for(lambda: self._queued or self._closed)
                if self._closed:
                    return
            try:
                self._send_next()
                self._unsent = False
            except Exception:  # the writer outlives a bad moment of the bus; logged once
                if not self._unsent:
                    log.exception("queued world model writes could not be sent")
                self._unsent = True

    def _send_next(self) -> None:
        """The writer: send one batch, then (not holding the send lock, so that a call
        is not held up) wait for its answer while the world model answers."""
        with self._sending:
            with self._wake:
                batch = self._queued[:MAX_BATCH]
                del self._queued[:MAX_BATCH]
                self._taken += len(batch)
            if not batch:
                return
            client = self.client
            if not self._paced and client.answered_sends != self._answers_unpaced:
                self._paced = True  # it answers again
            paced = self._paced
            self.batches += 1
            request_id = client.send("wm.upsert_many", [batch], track=paced)
        if paced and not client.wait_answered(request_id, PACE_TIMEOUT_S):
            self._paced = False
            self._answers_unpaced = client.answered_sends

    def _flush(self, due: int | None = None) -> None:
        """Send the queued writes (every one, or those up to the `due`-th ever taken), in
        batches, in order, without waiting for their answers (a call waits for its own,
        which comes after theirs)."""
        with self._sending:
            while True:
                with self._wake:
                    size = MAX_BATCH if due is None else min(MAX_BATCH, due - self._taken)
                    batch = self._queued[:max(size, 0)]
                    del self._queued[:len(batch)]
                    self._taken += len(batch)
                if not batch:
                    return
                self.batches += 1
                self.client.send("wm.upsert_many", [batch])

    def near(self, lat: float, lon: float, radius_m: float,
             kind: str | None = None) -> list[dict[str, Any]]:
        return list(self._call("wm.near", [lat, lon, radius_m, kind]))

    def intersecting(self, geometry: dict[str, Any],
                     kind: str | None = None) -> list[dict[str, Any]]:
        """Objects sharing a point with a GeoJSON geometry."""
        return list(self._call("wm.intersecting", [geometry, kind]))

    def within(self, geometry: dict[str, Any], kind: str | None = None) -> list[dict[str, Any]]:
        """Objects inside a GeoJSON geometry."""
        return list(self._call("wm.within", [geometry, kind]))

    def within_distance(self, geometry: dict[str, Any], distance_m: float,
                        kind: str | None = None) -> list[dict[str, Any]]:
        """Objects within `distance_m` of a GeoJSON geometry, nearest first."""
        return list(self._call("wm.within_distance", [geometry, distance_m, kind]))


class HttpWorldModel:
    """A world model behind the HTTP API of `mrss.actors.worldmodel.http`.

    With a `token` every request carries ``Authorization: Bearer <token>``.
    """

    def __init__(self, base_url: str, timeout: float = 5.0, *, token: str | None = None) -> None:
        self._base_url = base_url.rstrip("/")
        self.timeout = timeout
        self._headers = {"Content-Type": "application/json"}
        if token is not None:
            self._headers["Authorization"] = f"Bearer {token}"

    @property
    def base_url(self) -> str:
        """Where the API is, e.g. http://127.0.0.1:8765 (no trailing slash)."""
        return self._base_url

    def _request(self, method: str, path: str, body: Any = None) -> tuple[int, Any]:
        data = None if body is None else json.dumps(body).encode()
        base = self.base_url
        req = urllib.request.Request(base + path, data=data, method=method,
                                     headers=self._headers)
        try:
            with urllib.request.urlopen(req, timeout=self.timeout) as resp:
                return resp.status, json.loads(resp.read() or b"null")
        except urllib.error.HTTPError as exc:
            detail = exc.read().decode("utf-8", "replace")
            try:
                answer = json.loads(detail)
            except ValueError:
                answer = None
            if isinstance(answer, dict) and isinstance(answer.get("error"), str):
                detail = answer["error"]
            return exc.code, {"error": detail}
        except (OSError, ValueError) as exc:  # refused, reset, timed out, garbled
            raise WorldModelUnavailable(f"{method} {base}{path}: {exc}") from exc

    def _ok(self, status: int, body: Any, what: str) -> Any:
        if status >= 500:
            raise WorldModelUnavailable(f"{what}: HTTP {status}: {body.get('error', body)}")
        if status >= 400:
            raise WorldModelRejected(f"{what}: HTTP {status}: {body.get('error', body)}")
        return body

    def get(self, object_id: str) -> dict[str, Any] | None:
        status, body = self._request("GET", "/objects/" + quote(object_id, safe=""))
        if status == 404:
            return None
        return dict(self._ok(status, body, f"get {object_id!r}"))

    def objects(self, kind: str | None = None) -> list[dict[str, Any]]:
        query = "?" + urlencode({"kind": kind}) if kind else ""
        status, body = self._request("GET", "/objects" + query)
        return list(self._ok(status, body, "list")["objects"])

    def upsert(self, obj: dict[str, Any]) -> dict[str, Any]:
        status, body = self._request("POST", "/objects", obj)
        return dict(self._ok(status, body, "upsert"))

    def near(self, lat: float, lon: float, radius_m: float,
             kind: str | None = None) -> list[dict[str, Any]]:
        params: dict[str, Any] = {"lat": lat, "lon": lon, "radius_m": radius_m}
        if kind:
            params["kind"] = kind
        status, body = self._request("GET", "/objects?" + urlencode(params))
        return list(self._ok(status, body, "near")["objects"])


class WorldModelClient(HttpWorldModel):
    """The world model of a run over HTTP, its URL looked up again for every call.

    `url` names a fixed service (a deployment's own world model); without it the URL is
    read from `<run_dir>/worldmodel.url`, which the embedded world model writes when it
    starts. A missing file means the world model is not up (yet): WorldModelUnavailable.
    `token` is the world model's bearer token (`[worldmodel] token_file`/`token_env`).
    """

    def __init__(self, *, run_dir: Path | None = None, url: str | None = None,
                 timeout: float = 5.0, token: str | None = None) -> None:
        if not url and run_dir is None:
            raise ValueError("a world model client needs a run folder or a URL")
        super().__init__(url or "", timeout, token=token)
        self.run_dir = run_dir
        self.fixed_url = bool(url)

    @property
    def base_url(self) -> str:
        if self.fixed_url or self.run_dir is None:
            return self._base_url
        path = self.run_dir / WORLD_MODEL_URL_FILE
        try:
            url = path.read_text(encoding="utf-8").strip()
        except OSError as exc:
            raise WorldModelUnavailable(f"the world model is not up: no {path.name} in the "
                                        f"run folder ({exc.strerror})") from None
        if not url:
            raise WorldModelUnavailable(f"the world model is not up: {path.name} is empty")
        return url.rstrip("/")


class WorldModelAccess(Protocol):
    """A world model as the data layer sees it: plain JSON objects by id and kind."""

    def get(self, object_id: str) -> dict[str, Any] | None: ...

    def objects(self, kind: str | None = None) -> list[dict[str, Any]]: ...

    def upsert(self, obj: dict[str, Any]) -> dict[str, Any]: ...

    def near(self, lat: float, lon: float, radius_m: float,
             kind: str | None = None) -> list[dict[str, Any]]: ...
