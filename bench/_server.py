"""A real ``uvicorn`` serving depot on 127.0.0.1 for benchmarks (bounded, stops by itself)."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import httpx
from sqlalchemy import create_engine, text

ADMIN_TOKEN = "bench-admin-token-0123456789abcdef"
# How long a server may take to answer its readiness check: on a busy 2-core host the
# workers import OpenCV, scikit-learn and the app for well over a minute.
READY_WITHIN_S = 240
LOCAL_POSTGRES = "postgresql+psycopg://postgres@127.0.0.1:5432/test"


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def bench_database(name: str) -> str:
    """A fresh PostgreSQL database ``name`` on the local server, else a temporary SQLite file.

    With ``DEPOT_TEST_POSTGRES_URL`` naming a database of its own (not the shared ``test``),
    ``name`` is prefixed with it: two benchmarks running at once on one server (several
    people, one machine) would otherwise drop each other's databases mid-run."""
    base = os.environ.get("DEPOT_TEST_POSTGRES_URL", LOCAL_POSTGRES)
    own = base.rsplit("/", 1)[1].split("?")[0]
    if own not in ("", "test"):
        name = f"{own}_{name}"
    try:
        engine = create_engine(base, isolation_level="AUTOCOMMIT")
        with engine.connect() as connection:
            connection.execute(text(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)'))
            connection.execute(text(f'CREATE DATABASE "{name}"'))
        engine.dispose()
        return base.rsplit("/", 1)[0] + f"/{name}"
    except Exception as exc:
        print(f"(PostgreSQL unavailable: {type(exc).__name__}; using SQLite)")
        return f"sqlite:///{tempfile.mkdtemp()}/bench.sqlite3"


@contextmanager
def serve(
    database_url: str, *, workers: int = 2, extra_env: dict[str, str] | None = None
) -> Iterator[str]:
    """Migrate, start ``depot serve`` and yield its base URL; the server is killed afterwards."""
    data_dir = tempfile.mkdtemp(prefix="depot-bench-")
    env = {
        **os.environ,
        **(extra_env or {}),
        "DEPOT_DATABASE_URL": database_url,
        "DEPOT_DATA_DIR": data_dir,
        "DEPOT_ADMIN_TOKEN": ADMIN_TOKEN,
        "DEPOT_ENVIRONMENT": "test",
    }
    depot = str(Path(sys.executable).parent / "depot")
    subprocess.run([depot, "migrate"], env=env, check=True, capture_output=True)
    port = free_port()
    command = [depot, "serve", "--port", str(port), "--workers", str(workers)]
    with running(command, env, Path(data_dir), f"http://127.0.0.1:{port}/readyz") as _:
        yield f"http://127.0.0.1:{port}"


@contextmanager
def running(command: list[str], env: dict[str, str], log_dir: Path, ready: str) -> Iterator[None]:
    """Run ``command`` until the block ends; ready when ``ready`` answers 200."""
    log = open(log_dir / "server.log", "w")  # noqa: SIM115 - closed below
    process = subprocess.Popen(command, env=env, stdout=log, stderr=log)
    try:
        deadline = time.monotonic() + READY_WITHIN_S
        while time.monotonic() < deadline:
            try:
                if httpx.get(ready, timeout=1).status_code == 200:
                    break
            except httpx.HTTPError:
                pass
            time.sleep(0.2)
        else:
            raise RuntimeError(f"server did not become ready; see {log.name}")
        yield
    finally:
        process.terminate()
        try:
            process.wait(timeout=15)
        except subprocess.TimeoutExpired:
            process.kill()
        log.close()


def admin() -> dict[str, str]:
    return {"Authorization": f"Bearer {ADMIN_TOKEN}"}
