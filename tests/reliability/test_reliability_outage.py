"""Database outage: PostgreSQL restarted during load.

The test runs its own PostgreSQL (``initdb`` in a temporary directory, ``pg_ctl`` on a free
port) so it may stop it; the machine's server on 5432 is never touched. While the database is
down the service answers 503 with Retry-After (and /healthz stays 200); it recovers by itself,
and nothing acknowledged is lost.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import httpx
import pytest

from tests.reliability.conftest import ADMIN_HEADERS, report
from tests.reliability.dbcheck import assert_derived_cleanly, assert_nothing_lost
from tests.reliability.loadgen import Payloads, Stats, build_line, run_load
from tests.reliability.relkit import SOAK, PgCluster, Server, scratch_database


@dataclass
class Outage:
    stats: Stats
    probe: dict[str, Any]
    ready_after: int
    log: str
    url: str


def _probe(server: Server, key: str) -> dict[str, Any]:
    """What a device and a monitor see while the database is down."""
    ready = httpx.get(f"{server.url}/readyz", timeout=10)
    health = httpx.get(f"{server.url}/healthz", timeout=10)
    body = {"event_id": "probe-1", "occurred_at": "2026-11-23T10:00:00Z", "kind": "heartbeat"}
    event = httpx.post(
        f"{server.url}/api/v1/events", json=body, headers={"X-Device-Key": key}, timeout=30
    )
    return {
        "readyz": ready.status_code,
        "readyz_retry_after": ready.headers.get("retry-after"),
        "healthz": health.status_code,
        "event": event.status_code,
        "event_retry_after": event.headers.get("retry-after"),
        "event_type": event.headers.get("content-type"),
    }


def _run(tmp: Path, p: Payloads, seconds: float, down: float) -> Iterator[Outage]:
    with (
        PgCluster() as pg,
        scratch_database("depot_rel_outage", server=pg.url) as url,
        Server(url, tmp / "data") as server,
    ):
        server.migrate()
        server.start()
        devices = build_line(server.url, ADMIN_HEADERS)
        result: dict[str, Stats] = {}

        def load() -> None:
            result["stats"] = run_load(server.url, devices, p, seconds=seconds)

        loader = threading.Thread(target=load, daemon=True)
        loader.start()
        time.sleep(seconds / 4)
        pg.stop("fast")
        probe = _probe(server, devices[0].key)
        time.sleep(down)
        pg.start()
        loader.join(timeout=seconds + 240)
        assert not loader.is_alive(), "the simulated devices did not finish"
        ready = httpx.get(f"{server.url}/readyz", timeout=10).status_code
        server.stop()
        yield Outage(result["stats"], probe, ready, server.log_text(), url)


def _check_recovery(outage: Outage) -> None:
    stats, probe = outage.stats, outage.probe
    assert probe["readyz"] == 503 and probe["readyz_retry_after"]
    assert probe["healthz"] == 200
    assert probe["event"] == 503 and str(probe["event_retry_after"]).isdigit()
    assert str(probe["event_type"]).startswith("application/problem+json")
    assert outage.ready_after == 200, "the service did not recover by itself"
    assert stats.statuses.get(503, 0) > 0, "no device met the outage"
    assert stats.missing_retry_after == 0
    assert not stats.unacked and len(stats.acked) == len(stats.sent)
    assert_nothing_lost(outage.url, stats)
    assert_derived_cleanly(outage.url)


def _check_no_other_error(outage: Outage) -> None:
    assert not outage.stats.unexpected, outage.stats.unexpected[:5]
    assert set(outage.stats.statuses) <= {200, 201, 503}, outage.stats.statuses
    log = outage.log
    assert "Traceback" not in log, log[log.find("Traceback") - 300 :][:3000]


@pytest.fixture(scope="module")
def outage(
    request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory, payloads: Payloads
) -> Iterator[Outage]:
    for run in _run(tmp_path_factory.mktemp("outage"), payloads, 10, 3):
        figures = {**run.stats.summary(), "down_s": 3, "probe": run.probe}
        report(request, "database restarted during 10 s load", figures)
        yield run


def test_outage_answers_503_and_recovers_losing_nothing(outage: Outage) -> None:
    _check_recovery(outage)


def test_outage_gives_no_other_server_error(outage: Outage) -> None:
    _check_no_other_error(outage)


@pytest.mark.slow
@pytest.mark.skipif(not SOAK, reason="60 s load with a 10 s outage runs only with DEPOT_SOAK=1")
def test_database_outage_during_soak(
    request: pytest.FixtureRequest, tmp_path: Path, payloads: Payloads
) -> None:
    for run in _run(tmp_path, payloads, 60, 10):
        report(
            request,
            "database down 10 s during 60 s load",
            {**run.stats.summary(), "probe": run.probe},
        )
        _check_recovery(run)
        _check_no_other_error(run)
