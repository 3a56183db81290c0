"""Real processes for the reliability tests: PostgreSQL databases and clusters, ``depot serve``.

Everything listens on 127.0.0.1 only, every wait is bounded, and every process started here is
stopped by its context manager, also when the test fails.
"""

from __future__ import annotations

import os
import pwd
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from glob import glob
from pathlib import Path

import httpx
import pytest
from sqlalchemy import create_engine, text

ADMIN_TOKEN = "reliability-admin-token-7f3a9c2e5b1d4f60"
MAIN_POSTGRES = "postgresql+psycopg://postgres@127.0.0.1:5432/postgres"
DEPOT = str(Path(sys.executable).parent / "depot")
SOAK = os.environ.get("DEPOT_SOAK") == "1"


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _server_url() -> str:
    """The main server's maintenance database (``DEPOT_TEST_POSTGRES_URL``'s server if given)."""
    given = os.environ.get("DEPOT_TEST_POSTGRES_URL")
    return given.rsplit("/", 1)[0] + "/postgres" if given else MAIN_POSTGRES


@contextmanager
def scratch_database(name: str, server: str | None = None) -> Iterator[str]:
    """A fresh database ``name`` (created, yielded as a URL, dropped afterwards); skips without
    a reachable PostgreSQL."""
    admin_url = server or _server_url()
    try:
        engine = create_engine(admin_url, isolation_level="AUTOCOMMIT", connect_args={})
        with engine.connect() as connection:
            connection.execute(text(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)'))
            connection.execute(text(f'CREATE DATABASE "{name}"'))
    except Exception as exc:
        pytest.skip(f"PostgreSQL not reachable at {admin_url}: {type(exc).__name__}: {exc}")
    try:
        yield admin_url.rsplit("/", 1)[0] + f"/{name}"
    finally:
        try:
            with engine.connect() as connection:
                connection.execute(text(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)'))
        except Exception as exc:
            print(f"could not drop database {name}: {type(exc).__name__}")
        engine.dispose()


def depot_env(database_url: str, data_dir: Path) -> dict[str, str]:
    return {
        **os.environ,
        "DEPOT_DATABASE_URL": database_url,
        "DEPOT_DATA_DIR": str(data_dir),
        "DEPOT_ADMIN_TOKEN": ADMIN_TOKEN,
        "DEPOT_ENVIRONMENT": "test",
    }


def run_depot(env: dict[str, str], *args: str, timeout: float = 300) -> subprocess.CompletedProcess:
    return subprocess.run(
        [DEPOT, *args], env=env, capture_output=True, text=True, timeout=timeout, check=False
    )


def _stop_group(process: subprocess.Popen, sig: int, wait: float) -> None:
    """Signal the whole process group (uvicorn's supervisor and its workers)."""
    if process.poll() is not None:
        return
    try:
        os.killpg(process.pid, sig)
    except ProcessLookupError:
        return
    try:
        process.wait(timeout=wait)
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        process.wait(timeout=10)


class Server:
    """``depot serve`` in its own process group on a fixed port, so it can be killed and
    restarted on the same address."""

    def __init__(self, database_url: str, data_dir: Path, *, workers: int = 2) -> None:
        self.env = depot_env(database_url, data_dir)
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.workers = workers
        self.log_path = data_dir / "server.log"
        self.process: subprocess.Popen | None = None
        data_dir.mkdir(parents=True, exist_ok=True)

    def migrate(self) -> None:
        done = run_depot(self.env, "migrate")
        assert done.returncode == 0, done.stderr

    def start(self, *, ready_within: float = 60) -> None:
        args = ["serve", "--port", str(self.port), "--workers", str(self.workers)]
        with open(self.log_path, "a") as log:
            self.process = subprocess.Popen(
                [DEPOT, *args], env=self.env, stdout=log, stderr=log, start_new_session=True
            )
        deadline = time.monotonic() + ready_within
        while time.monotonic() < deadline:
            if self.process.poll() is not None:
                raise RuntimeError(f"depot serve exited; see {self.log_path}")
            try:
                if httpx.get(f"{self.url}/healthz", timeout=1).status_code == 200:
                    return
            except httpx.HTTPError:
                pass
            time.sleep(0.1)
        self.stop()
        raise RuntimeError(f"depot serve not ready within {ready_within} s; see {self.log_path}")

    def kill(self) -> None:
        """SIGKILL the supervisor and every worker at once: nothing gets to clean up."""
        if self.process is not None:
            _stop_group(self.process, signal.SIGKILL, 10)

    def stop(self) -> None:
        if self.process is not None:
            _stop_group(self.process, signal.SIGTERM, 15)

    def log_text(self) -> str:
        return self.log_path.read_text(errors="replace") if self.log_path.exists() else ""

    def __enter__(self) -> Server:
        return self

    def __exit__(self, *_: object) -> None:
        self.stop()


def _pg_bin() -> Path | None:
    found = sorted(glob("/usr/lib/postgresql/*/bin/pg_ctl"))
    if found:
        return Path(found[-1]).parent
    which = shutil.which("pg_ctl")
    return Path(which).parent if which else None


class PgCluster:
    """A private PostgreSQL instance in a temporary directory, which the test may stop."""

    def __init__(self) -> None:
        bindir = _pg_bin()
        if bindir is None:
            pytest.skip("initdb/pg_ctl not found (looked in /usr/lib/postgresql/*/bin and PATH)")
        self.bindir = bindir
        self.prefix: list[str] = []
        self.root = Path(tempfile.mkdtemp(prefix="depot-rel-pg-"))
        if os.geteuid() == 0:  # initdb refuses root: run the cluster as the postgres user
            try:
                owner = pwd.getpwnam("postgres")
            except KeyError:
                pytest.skip("running as root and there is no 'postgres' user to run initdb as")
            os.chown(self.root, owner.pw_uid, owner.pw_gid)
            self.prefix = ["runuser", "-u", "postgres", "--"]
        self.data = self.root / "data"
        self.port = free_port()
        self.url = f"postgresql+psycopg://postgres@127.0.0.1:{self.port}/postgres"
        done = self._run(
            "initdb", "-D", str(self.data), "-U", "postgres", "--auth=trust", "-E", "UTF8"
        )
        if done.returncode != 0:
            shutil.rmtree(self.root, ignore_errors=True)
            pytest.skip(f"initdb failed: {done.stderr.strip()[:300]}")

    def _run(self, tool: str, *args: str) -> subprocess.CompletedProcess:
        command = [*self.prefix, str(self.bindir / tool), *args]
        return subprocess.run(command, capture_output=True, text=True, timeout=120, check=False)

    def start(self) -> None:
        options = f"-p {self.port} -k {self.root} -c listen_addresses=127.0.0.1 -c fsync=on"
        done = self._run(
            "pg_ctl",
            "-D",
            str(self.data),
            "-o",
            options,
            "-l",
            str(self.root / "pg.log"),
            "-w",
            "-t",
            "60",
            "start",
        )
        assert done.returncode == 0, done.stdout + done.stderr

    def stop(self, mode: str = "fast") -> None:
        self._run("pg_ctl", "-D", str(self.data), "-m", mode, "-w", "-t", "60", "stop")

    def __enter__(self) -> PgCluster:
        self.start()
        return self

    def __exit__(self, *_: object) -> None:
        self.stop("immediate")
        shutil.rmtree(self.root, ignore_errors=True)
