"""Fixtures of the reliability tests: a real server on a scratch PostgreSQL database."""

from __future__ import annotations

import json
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from tests.reliability.loadgen import Device, Payloads, build_line
from tests.reliability.relkit import ADMIN_TOKEN, Server, scratch_database

ADMIN_HEADERS = {"Authorization": f"Bearer {ADMIN_TOKEN}"}


class LiveLine:
    def __init__(self, server: Server, devices: list[Device], url: str) -> None:
        self.server, self.devices, self.database_url = server, devices, url


@pytest.fixture(scope="session")
def payloads() -> Payloads:
    return Payloads()


@pytest.fixture
def live_line(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[LiveLine]:
    """``depot serve`` (2 workers) on a fresh PostgreSQL database with the 50-device line."""
    # The pid keeps two runs on one machine (two people's make test) off each other's database.
    name = f"depot_rel_{os.getpid()}_{request.node.name.split('[')[0][-36:]}".lower()
    with scratch_database(name) as url, Server(url, tmp_path / "data") as server:
        server.migrate()
        server.start()
        devices = build_line(server.url, ADMIN_HEADERS)
        yield LiveLine(server, devices, url)
        server.stop()


def report(request: pytest.FixtureRequest, title: str, figures: dict[str, Any]) -> None:
    """Print the measured figures in the test output (also with -q) for docs/RELIABILITY.md."""
    line = f"[reliability] {title}: {json.dumps(figures)}"
    capture = request.config.pluginmanager.get_plugin("capturemanager")
    if capture is None:
        print(line)
        return
    with capture.global_and_fixture_disabled():
        print(f"\n{line}")
