"""A private PostgreSQL + PostGIS cluster for tests: initdb in a temp folder, a free
loopback port, started and stopped with pg_ctl, killable to test crashes.

PostgreSQL refuses to run as root; as root the cluster runs as the `postgres` user.
`MRSS_REQUIRE_POSTGIS=1` (set by .ci/run) turns "cannot have PostGIS here" from a skip
into a failure.
"""

from __future__ import annotations

import glob
import os
import shutil
import signal
import subprocess
import tempfile
from pathlib import Path

import psutil
import pytest

from mrss.testing import free_port, wait_until

REQUIRE_ENV = "MRSS_REQUIRE_POSTGIS"


def unavailable(reason: str) -> None:
    """Skip the test, or fail it when PostGIS is required (CI)."""
    message = f"PostGIS tests need PostgreSQL 15 with postgresql-15-postgis-3: {reason}"
    if os.environ.get(REQUIRE_ENV) == "1":
        pytest.fail(f"{message} ({REQUIRE_ENV}=1)", pytrace=False)
    pytest.skip(message)


def find_bin_dir() -> Path | None:
    """A PostgreSQL bin folder whose server finds the PostGIS extension files."""
    candidates = sorted(glob.glob("/usr/lib/postgresql/*/bin"), reverse=True)
    which = shutil.which("initdb")
    if which:
        candidates.append(str(Path(which).resolve().parent))
    for folder in candidates:
        bindir = Path(folder)
        config = bindir / "pg_config"
        if not (bindir / "initdb").exists():
            continue
        share = subprocess.run([str(config), "--sharedir"], capture_output=True, text=True,
                               check=False).stdout.strip() if config.exists() else ""
        if share and (Path(share) / "extension" / "postgis.control").exists():
            return bindir
    return None


class PgCluster:
    """One PostgreSQL server of its own (`start`, `kill`, `stop`)."""

    def __init__(self) -> None:
        bindir = find_bin_dir()
        if bindir is None:
            unavailable("no PostgreSQL bin folder with the postgis extension files")
        assert bindir is not None
        self.bindir = bindir
        self.as_root = os.geteuid() == 0
        # As root the folder is the postgres user's: under /tmp, which it can reach (and
        # a short path keeps the server's Unix socket under the length limit).
        where = "/tmp" if self.as_root and os.path.isdir("/tmp") else None
        self.root = Path(tempfile.mkdtemp(prefix="mrss-pg-", dir=where))
        self.data = self.root / "data"
        self.port = free_port()
        if self.as_root:
            shutil.chown(self.root, "postgres", "postgres")
        try:
            self._run("initdb", "-D", str(self.data), "-A", "trust", "-U", "mrss", "-E",
                      "UTF8", "--no-sync", "--no-instructions")
        except (OSError, subprocess.CalledProcessError) as exc:
            shutil.rmtree(self.root, ignore_errors=True)
            unavailable(f"initdb failed: {getattr(exc, 'stderr', '') or exc}")

    def _run(self, tool: str, *args: str) -> subprocess.CompletedProcess[str]:
        command = [str(self.bindir / tool), *args]
        if self.as_root:
            command = ["runuser", "-u", "postgres", "--", *command]
        return subprocess.run(command, capture_output=True, text=True, check=True, timeout=120,
                              cwd=self.root)

    def url(self, dbname: str = "postgres") -> str:
        """libpq URL of a database of this cluster."""
        return f"postgresql://mrss@127.0.0.1:{self.port}/{dbname}"

    def start(self) -> None:
        """Start the server and wait until it accepts connections."""
        options = (f"-p {self.port} -c listen_addresses=127.0.0.1 -k {self.root} "
                   "-c fsync=off -c max_connections=30 -c shared_buffers=16MB")
        self._run("pg_ctl", "-D", str(self.data), "-o", options, "-l",
                  str(self.root / "server.log"), "-w", "-t", "60", "start")

    def postmaster_pid(self) -> int | None:
        """The server's pid, or None when it is not running."""
        try:
            pid = int((self.data / "postmaster.pid").read_text().split()[0])
        except (OSError, ValueError, IndexError):
            return None
        return pid if psutil.pid_exists(pid) else None

    def processes(self) -> list[psutil.Process]:
        """The postmaster and all its processes (none when it is not running)."""
        pid = self.postmaster_pid()
        if pid is None:
            return []
        server = psutil.Process(pid)
        return [server, *server.children(recursive=True)]

    def signal_all(self, signum: int) -> list[psutil.Process]:
        """Send `signum` to every process of the server; the processes."""
        processes = self.processes()
        for each in processes:
            try:
                each.send_signal(signum)
            except psutil.NoSuchProcess:
                pass
        return processes

    def kill(self) -> None:
        """Crash the server: SIGKILL to the postmaster and all its processes."""
        psutil.wait_procs(self.signal_all(signal.SIGKILL), timeout=30)

    def freeze(self) -> None:
        """SIGSTOP the server: connections stay open, nothing answers."""
        self.signal_all(signal.SIGSTOP)

    def thaw(self) -> None:
        """SIGCONT the server."""
        self.signal_all(signal.SIGCONT)

    def restart_after_crash(self) -> None:
        """Start again after `kill` (the server recovers from its WAL)."""
        def started() -> bool:
            try:
                self.start()
            except subprocess.CalledProcessError:
                return False
            return True
        wait_until(started, timeout=60, interval=0.2, message="PostgreSQL restarted")

    def stop(self) -> None:
        """Stop the server (fast) and remove its folder."""
        try:
            if self.postmaster_pid() is not None:
                self._run("pg_ctl", "-D", str(self.data), "-m", "immediate", "-w", "stop")
        finally:
            shutil.rmtree(self.root, ignore_errors=True)

    def create_database(self, name: str) -> str:
        """A new empty database (PostGIS is created by the store's migration)."""
        import psycopg
        with psycopg.connect(self.url(), autocommit=True) as conn:
            conn.execute(f'CREATE DATABASE "{name}"')
        return self.url(name)


def started_cluster() -> PgCluster:
    """A running cluster where CREATE EXTENSION postgis works (skip/fail if none)."""
    try:
        import psycopg
    except ImportError:
        unavailable("psycopg is not installed")
    cluster = PgCluster()
    try:
        cluster.start()
        with psycopg.connect(cluster.url(), autocommit=True) as conn:
            conn.execute("CREATE EXTENSION postgis")
            conn.execute("DROP EXTENSION postgis")
    except (subprocess.CalledProcessError, psycopg.Error) as exc:
        log = (cluster.root / "server.log")
        detail = getattr(exc, "stderr", "") or str(exc)
        tail = log.read_text(errors="replace")[-500:] if log.exists() else ""
        cluster.stop()
        unavailable(f"{detail.strip()} {tail.strip()}")
    return cluster
