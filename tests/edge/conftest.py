"""Fixtures for the edge tests: a Mosquitto with passwords and TLS, a restartable amqtt.

The world model's (a private PostGIS server, a store of each backend) are
tests/actors/worldmodel/conftest.py's."""

from __future__ import annotations

import getpass
import socket
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

from mrss.testing import find_mosquitto, free_port, wait_until
from tests.edge.fixture_project import PROJECT_FIXTURE as PROJECT_FIXTURE
from tests.mosquitto import require_mosquitto


def _accepting(host: str, port: int) -> bool:
    try:
        with socket.create_connection((host, port), timeout=0.2):
            return True
    except OSError:
        return False


def _stop(proc: subprocess.Popen[bytes]) -> None:
    proc.terminate()
    try:
        proc.wait(timeout=5)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()


@dataclass(frozen=True)
class SecureBroker:
    """A Mosquitto that wants user `mrss` / password `s3cret`, plain and TLS listeners."""

    port: int
    tls_port: int
    ca_file: Path
    username: str = "mrss"
    password: str = "s3cret"


@pytest.fixture(scope="session")
def secure_mosquitto() -> Iterator[SecureBroker]:
    binary = require_mosquitto(find_mosquitto(), "the password and TLS tests",
                               ("mosquitto_passwd", "openssl"))
    with tempfile.TemporaryDirectory(prefix="mrss-secure-") as tmp:
        d = Path(tmp)
        subprocess.run(
            ["openssl", "req", "-x509", "-newkey", "rsa:2048", "-nodes", "-days", "1",
             "-keyout", str(d / "key.pem"), "-out", str(d / "cert.pem"), "-subj", "/CN=localhost",
             "-addext", "subjectAltName=IP:127.0.0.1,DNS:localhost"],
            check=True, capture_output=True)
        subprocess.run(["mosquitto_passwd", "-b", "-c", str(d / "passwd"), "mrss", "s3cret"],
                       check=True, capture_output=True)
        (d / "passwd").chmod(0o600)
        port, tls_port = free_port(), free_port()
        (d / "mosquitto.conf").write_text(
            f"user {getpass.getuser()}\n"  # as root, mosquitto would drop to a user who
            # cannot read the private temporary folder
            f"per_listener_settings false\nallow_anonymous false\npassword_file {d / 'passwd'}\n"
            f"persistence false\nlog_type error\n"
            f"listener {port} 127.0.0.1\n"
            f"listener {tls_port} 127.0.0.1\ncafile {d / 'cert.pem'}\n"
            f"certfile {d / 'cert.pem'}\nkeyfile {d / 'key.pem'}\n")
        proc = subprocess.Popen([binary, "-c", str(d / "mosquitto.conf")],
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            wait_until(lambda: _accepting("127.0.0.1", port) and _accepting("127.0.0.1",
                                                                            tls_port),
                       timeout=10, message="secure mosquitto")
            yield SecureBroker(port, tls_port, d / "cert.pem")
        finally:
            _stop(proc)


class RestartableAmqtt:
    """The embedded amqtt broker in a child process, stoppable and restartable on one port."""

    def __init__(self) -> None:
        self.port = free_port()
        self.proc: subprocess.Popen[bytes] | None = None

    @property
    def url(self) -> str:
        return f"mqtt://127.0.0.1:{self.port}"

    def start(self) -> None:
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "mrss.actors.broker.service", "--host", "127.0.0.1", "--port",
             str(self.port)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        wait_until(lambda: _accepting("127.0.0.1", self.port), timeout=20,
                   message="amqtt accepting")

    def stop(self) -> None:
        if self.proc is not None:
            _stop(self.proc)
            self.proc = None


@pytest.fixture()
def restartable_amqtt() -> Iterator[RestartableAmqtt]:
    broker = RestartableAmqtt()
    broker.start()
    try:
        yield broker
    finally:
        broker.stop()
