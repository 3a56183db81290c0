"""A real uvicorn server in a background thread, on its own SQLite database, for browser tests."""

from __future__ import annotations

import os
import socket
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import httpx
import uvicorn

from core import database
from core.settings import get_settings
from service.migrate import upgrade

HTTP_TIMEOUT_S = 30.0
"""How long a test's request to the live server may take. The server shares the test's
process and a loaded 2-core CI machine with Chromium: a snapshot upload once took more
than httpx's default 5 s there, which says nothing about the screen under test."""


def live_client(url: str) -> httpx.Client:
    """A client of the live server at ``url`` with :data:`HTTP_TIMEOUT_S`."""
    return httpx.Client(base_url=url, timeout=HTTP_TIMEOUT_S)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _reset_caches() -> None:
    get_settings.cache_clear()
    database.get_engine.cache_clear()
    database.get_sessionmaker.cache_clear()


@contextmanager
def live_server(data_dir: Path) -> Iterator[str]:
    """Serve the app on 127.0.0.1 with ``data_dir``'s SQLite database; stops on exit."""
    saved = {k: os.environ.get(k) for k in ("DEPOT_DATA_DIR", "DEPOT_DATABASE_URL")}
    os.environ["DEPOT_DATA_DIR"] = str(data_dir)
    os.environ["DEPOT_DATABASE_URL"] = f"sqlite:///{data_dir / 'live.sqlite3'}"
    _reset_caches()
    upgrade(os.environ["DEPOT_DATABASE_URL"])
    from service.app import create_app
    from service.header_deadline import HeaderDeadlineProtocol

    port = _free_port()
    server = uvicorn.Server(
        uvicorn.Config(
            create_app(),
            host="127.0.0.1",
            port=port,
            log_level="warning",
            http=HeaderDeadlineProtocol,  # as `depot serve` runs
        )
    )
    thread = threading.Thread(target=server.run, daemon=True)
    thread.start()
    try:
        deadline = time.monotonic() + 30
        while not server.started and time.monotonic() < deadline:
            time.sleep(0.05)
        assert server.started, "the live server did not start"
        yield f"http://127.0.0.1:{port}"
    finally:
        server.should_exit = True
        thread.join(timeout=15)
        database.get_engine().dispose()
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value
        _reset_caches()
