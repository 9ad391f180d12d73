"""The embedded MQTT broker (amqtt), used when a project names no broker URL.

`resolve_broker(config)` decides: with `[broker] url` set, that broker is used and
nothing embedded starts; without it, a free loopback port is chosen and the
`EmbeddedBroker` component serves there, writing the URL to `<run_dir>/broker.url` for
the components started after it (`mrss.config.broker.resolved_broker_url`). A
supervisor that prefers to decide up front can use `with_broker_url(config)` and hand
every component the filled-in configuration. Also runnable on its own:
`python -m mrss.actors.broker.service --host 127.0.0.1 --port N` serves until SIGTERM/SIGINT.

Which broker serves (`[broker.embedded] engine`, a `BrokerEngine`): "auto" (the
default) runs Mosquitto where it is installed (PATH, /usr/sbin) and no password file is
set, with its sessions persisted in `<run_dir>/broker/` (`mrss.actors.broker.mosquitto`:
what is durable when); otherwise amqtt in this process. "mosquitto" requires it (a
ConfigError without it, or with a password file: Mosquitto cannot read amqtt's Argon2
hashes), "amqtt" always uses amqtt.

Sessions with amqtt: clients are accepted without credentials (the broker listens on
loopback unless configured) unless `[broker.embedded] password_file` names a password
file (`mrss.actors.broker.passwords`): then only its users get in. Either way not as
amqtt's "anonymous" clients, whose sessions amqtt never keeps. So a client connecting
with clean_session false (the events manager) keeps its session and its QoS 1
subscriptions while it is away, and messages published meanwhile wait for it. The
limit of this fallback: amqtt keeps sessions in memory only, so a restart of the
embedded amqtt broker loses them, with any message queued for an absent client or not
yet acknowledged by one (the component logs a WARNING saying so when it starts amqtt).

Refused connections: amqtt logs an ERROR and a WARNING for every connection closed or
garbled before its CONNECT (a port scan, a health check's bare TCP connect). The
`connection_refusals` filter on its logger counts them instead, by client address, in
a `RejectionLog` ("MQTT connection": in the component's Rejections reports, logged
once per interval).

project.toml:
    [broker]
    url = "mqtt://host:1883"        # or mqtts://; absent: the embedded broker
    [broker.embedded]
    host = "127.0.0.1"              # loopback unless configured
    port = 0                        # 0: a free port
    password_file = "secrets/mqtt.passwd"   # only its users get in ([broker] username
                                    # and password / password_env are the project's login)
    engine = "auto"                 # "mosquitto" | "amqtt": which broker serves
    autosave_changes = 1            # Mosquitto: save its sessions after N changes
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import copy
import logging
import re
import signal
import sys
import threading
from collections.abc import Mapping
from pathlib import Path
from typing import Any, ClassVar
from urllib.parse import urlsplit

from mrss.actors.broker.engine import BrokerEngine, broker_engine, table_of
from mrss.actors.broker.mosquitto import MosquittoProcess
from mrss.actors.broker.passwords import PASSWORD_FILE_KEY, password_file_problem
from mrss.edge.rejections import LoggedRefusals, RejectionLog
from mrss.errors import ConfigError, MrssError
from mrss.options import Check, Option, OptionValues
from mrss.ports import free_port
from mrss.programs import find_mosquitto
from mrss.runtime.component import Component, ComponentContext
from mrss.textfile import write_whole

log = logging.getLogger("mrss.broker")
#: The embedded Mosquitto's folder under the run folder: its configuration, database, pid.
STATE_DIR = "broker"



class BrokerError(MrssError):
    """The embedded broker could not start."""


def broker_config(host: str, port: int, password_file: str | None = None) -> dict[str, Any]:
    """amqtt configuration: one plain TCP listener, sessions kept; every client accepted,
    or with a `password_file` (an absolute path) only its users."""
    plugin: dict[str, Any] = {"mrss.actors.broker.sessions.OpenSessionsAuthPlugin": {}}
    if password_file:
        plugin = {"mrss.actors.broker.sessions.PasswordFileAuthPlugin":
                  {"password_file": password_file}}
    return {
        "listeners": {"default": {"type": "tcp", "bind": f"{host}:{port}"}},
        "plugins": plugin,
    }


#: The keys of `[broker]` and `[broker.embedded]` (read by resolve_broker; `mrss check`
#: validates them).
BROKER_OPTIONS: tuple[Option, ...] = (
    Option("url", str, None, "an outside broker, mqtt://host:port (none: the embedded one)",
           Check.URL),
    Option("embedded", dict, {}, "the embedded broker's host and port"),
    # how every MQTT client of the project (events, links, simulators) logs in and keeps
    # its connection: read by mrss.edge.mqtt_client.MqttSettings.from_config
    Option("username", str, None, "login name"),
    Option("password", str, None, "login password (better: password_env)"),
    Option("password_env", str, None, "the environment variable holding the password"),
    Option("ca_certs", str, None, "CA certificates file for mqtts://"),
    Option("certfile", str, None, "client certificate file for mqtts://"),
    Option("keyfile", str, None, "client key file for mqtts://"),
    Option("tls_insecure", bool, False, "skip the server certificate's host name check"),
    Option("keepalive", int, 30, "seconds between MQTT keepalives", Check.POSITIVE),
    Option("reconnect_min", float, 0.2, "first reconnect delay (s)", Check.POSITIVE),
    Option("reconnect_max", float, 30.0, "longest reconnect delay (s)", Check.POSITIVE),
)
BROKER_EMBEDDED_OPTIONS: tuple[Option, ...] = (
    Option("host", str, "127.0.0.1", "the address the embedded broker listens on"),
    Option("port", int, 0, "its port (0: a free one)", Check.PORT),
    Option(PASSWORD_FILE_KEY, str, None, "user:argon2-hash lines (python -m "
           "mrss.actors.broker.passwords FILE USER); only those users may connect",
           Check.PASSWORD_FILE),
    Option("engine", str, BrokerEngine.AUTO.value, "which broker serves: auto (Mosquitto "
           "where installed and no password file, else amqtt), mosquitto or amqtt",
           choices=tuple(e.value for e in BrokerEngine)),
    Option("autosave_changes", int, 1, "Mosquitto: write its sessions to disk after this "
           "many changes (1: after each queued message or subscription)", Check.POSITIVE),
)


def embedded_password_file(config: Mapping[str, Any], project_dir: Path | None) -> str | None:
    """The embedded broker's password file (absolute), or None; ConfigError naming the key
    when it is unusable."""
    section = config.get("broker", {})
    embedded = section.get("embedded", {}) if isinstance(section, Mapping) else {}
    value = embedded.get(PASSWORD_FILE_KEY) if isinstance(embedded, Mapping) else None
    if value is None:
        return None
    key = f"broker.embedded.{PASSWORD_FILE_KEY}"
    if not isinstance(value, str) or not value:
        raise ConfigError("must be a file name in the project folder", key=key)
    path = Path(value)
    if project_dir is not None and not path.is_absolute():
        path = project_dir / path
    problem = password_file_problem(path, value)
    if problem:
        raise ConfigError(problem, key=key)
    return str(path.resolve())


def resolve_broker(config: Mapping[str, Any]) -> tuple[str, bool]:
    """The broker URL every adapter and link uses, and whether the embedded one must start."""
    section = config.get("broker", {})
    if not isinstance(section, Mapping):
        raise ConfigError("[broker] must be a table", key="broker")
    url = section.get("url")
    if url:
        if not isinstance(url, str) or urlsplit(url).scheme not in ("mqtt", "mqtts"):
            raise ConfigError(f"{url!r} must be an mqtt:// or mqtts:// URL", key="broker.url")
        return url, False
    embedded = section.get("embedded", {})
    if not isinstance(embedded, Mapping):
        raise ConfigError("[broker.embedded] must be a table", key="broker.embedded")
    declared = OptionValues(BROKER_EMBEDDED_OPTIONS, embedded, section="broker.embedded")
    host, port = declared.raw("host"), declared.raw("port")  # judged together below
    if not isinstance(host, str) or isinstance(port, bool) or not isinstance(port, int) \
            or not 0 <= port < 65536:
        raise ConfigError("host must be a string and port an integer in 0..65535",
                          key="broker.embedded")
    return f"mqtt://{host}:{port or free_port(host)}", True


def with_broker_url(config: Mapping[str, Any]) -> tuple[dict[str, Any], bool]:
    """A copy of `config` whose `[broker] url` is set; True when it is the embedded broker."""
    url, embedded = resolve_broker(config)
    out = copy.deepcopy(dict(config))
    section = dict(out.get("broker", {}))
    section["url"] = url
    section["embedded_running"] = embedded
    out["broker"] = section
    return out, embedded


async def serve(host: str, port: int, stop: asyncio.Event,
                started: threading.Event | None = None, password_file: str | None = None
                ) -> None:
    """Run the broker until `stop` is set (`started` is set once it listens)."""
    from amqtt.broker import Broker

    broker = Broker(broker_config(host, port, password_file))
    await broker.start()
    log.info("embedded MQTT broker listening on %s:%d%s", host, port,
             " (password file: only its users)" if password_file else "")
    if started is not None:
        started.set()
    try:
        await stop.wait()
    finally:
        await broker.shutdown()


AMQTT_BROKER_LOGGER = "amqtt.broker"
_CLIENT = r"\(client @=(?P<source>.*):\d+\)"  # amqtt's format_client_message


def connection_refusals() -> LoggedRefusals:
    """The filter of amqtt's broker logger: a connection that closes or sends garbage
    before its CONNECT is a refused "MQTT connection" (amqtt logs an ERROR and a WARNING
    for each, a port scan or a health check's bare TCP connect among them)."""
    return LoggedRefusals(RejectionLog(log, "MQTT connection"), [
        (re.compile(rf"^No data from {_CLIENT}"), "closed before CONNECT"),
        (re.compile(rf"^\[MQTT-3\.1\.0-1\] {_CLIENT}"), "first packet not CONNECT"),
        (re.compile(rf"^Invalid connection from {_CLIENT}"), "invalid CONNECT"),
    ], echoes=[re.compile(r"^Failed to initialize client session")])


class EmbeddedBroker(Component):
    """Component: amqtt on its own event loop thread, when no `[broker] url` is configured.

    It writes its URL to `<run_dir>/broker.url`, where the other components find it, and
    a restarted incarnation serves at the same URL again so clients simply reconnect.
    """

    #: The options this component reads (`mrss check` validates them; docs/config.md).
    OPTIONS: ClassVar[tuple[Option, ...]] = ()

    def __init__(self) -> None:
        self.mosquitto: MosquittoProcess | None = None
        self._thread: threading.Thread | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._stop: asyncio.Event | None = None
        self._error: BaseException | None = None
        self.url = ""
        #: amqtt's per-connection refusals, counted and logged once per interval.
        self.refusals = connection_refusals()

    def start(self, ctx: ComponentContext) -> None:
        """Component entry: serve on loopback unless the project names a broker."""
        from mrss.config.broker import BROKER_URL_FILE
        from mrss.runtime.edge import edge_config

        config = edge_config(ctx, "broker")
        url, embedded = resolve_broker(config)
        if not embedded:
            log.info("broker %s is configured; the embedded broker does not start", url)
            return
        password_file = embedded_password_file(config, ctx.project_dir)
        url_file = ctx.run_dir / BROKER_URL_FILE
        if url_file.is_file():  # a restart: same port, so clients reconnect to it
            url = url_file.read_text(encoding="utf-8").strip() or url
        binary = find_mosquitto()
        values = OptionValues(BROKER_EMBEDDED_OPTIONS, table_of(config, "broker", "embedded"),
                              section="broker.embedded")
        engine = broker_engine(values["engine"], password_file, binary)
        if engine is BrokerEngine.MOSQUITTO:
            assert binary is not None
            autosave = values.whole("autosave_changes")
            self.mosquitto = MosquittoProcess(binary, ctx.run_dir / STATE_DIR,
                                              autosave_changes=autosave)
            parts = urlsplit(url)
            assert parts.hostname is not None and parts.port is not None
            try:
                self.mosquitto.start(parts.hostname, parts.port, on_exit=ctx.fail)
            except (OSError, RuntimeError) as exc:
                raise BrokerError(f"embedded MQTT broker did not start: {exc}") from None
            self.url = url
        else:
            log.warning("embedded MQTT broker is amqtt (%s): its sessions live in memory "
                        "only, so a broker restart loses the messages queued for absent "
                        "clients", "a password file is set" if password_file else
                        "no mosquitto installed" if binary is None else "engine = amqtt")
            self.serve_at(url, password_file=password_file)
        write_whole(url_file, url + "\n")

    def serve_at(self, url: str, timeout: float = 20.0, *,
                 password_file: str | None = None) -> None:
        """Start serving at `url` (mqtt://host:port), with only the users of
        `password_file` if given; BrokerError if it does not come up."""
        parts = urlsplit(url)
        if parts.scheme != "mqtt" or not parts.hostname or not parts.port:
            raise ConfigError(f"the embedded broker needs mqtt://host:port, not {url!r}",
                              key="broker.url")
        host, port = parts.hostname, parts.port
        for name in ("amqtt", "transitions"):
            logging.getLogger(name).setLevel(logging.WARNING)
        logging.getLogger(AMQTT_BROKER_LOGGER).addFilter(self.refusals)
        started = threading.Event()
        self._loop = asyncio.new_event_loop()

        def run() -> None:
            assert self._loop is not None
            asyncio.set_event_loop(self._loop)
            self._stop = asyncio.Event()
            try:
                self._loop.run_until_complete(serve(host, port, self._stop, started,
                                                    password_file))
            except BaseException as exc:  # reported to start() below
                self._error = exc
                started.set()
            finally:
                self._loop.close()

        self._thread = threading.Thread(target=run, name="embedded-broker", daemon=True)
        self._thread.start()
        if not started.wait(timeout) or self._error is not None:
            raise BrokerError(f"embedded MQTT broker did not start on {host}:{port}: "
                              f"{self._error!r}")
        self.url = url

    @property
    def running(self) -> bool:
        """True while the broker (Mosquitto, or amqtt's thread) serves."""
        if self.mosquitto is not None:
            return self.mosquitto.running
        return self._thread is not None and self._thread.is_alive()

    def stop(self) -> None:
        """Shut the broker down (Mosquitto writes its sessions) and join its thread."""
        if self.mosquitto is not None:
            self.mosquitto.stop()
        loop, stop = self._loop, self._stop
        if loop is not None and stop is not None and self.running:
            # The loop may close between the check and the call (a broker that failed to
            # start ends by itself): then there is nothing left to stop.
            with contextlib.suppress(RuntimeError):
                loop.call_soon_threadsafe(stop.set)
        if self._thread is not None:
            self._thread.join(timeout=10)
        logging.getLogger(AMQTT_BROKER_LOGGER).removeFilter(self.refusals)
        self.refusals.rejections.flush()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m mrss.actors.broker.service")
    parser.add_argument("--host", default="127.0.0.1")
    parser.add_argument("--port", type=int, default=1883)
    parser.add_argument("--password-file", default=None,
                        help="only the users of this file (python -m mrss.actors.broker.passwords)")
    args = parser.parse_args(argv)
    password_file = None
    if args.password_file:
        problem = password_file_problem(Path(args.password_file))
        if problem:
            print(f"python -m mrss.actors.broker.service: {problem}", file=sys.stderr)
            return 2
        password_file = str(Path(args.password_file).resolve())
    logging.basicConfig(level=logging.WARNING)

    async def runner() -> None:
        stop = asyncio.Event()
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGTERM, signal.SIGINT):
            loop.add_signal_handler(sig, stop.set)
        await serve(args.host, args.port, stop, password_file=password_file)

    asyncio.run(runner())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
