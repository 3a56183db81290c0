"""Load: 50 simulated devices against a real uvicorn (2 workers) on PostgreSQL.

Short form (10 s) in ``make test``; the 60 s form only with ``DEPOT_SOAK=1`` (``make soak``).
"""

from __future__ import annotations

import pytest

from tests.reliability.conftest import LiveLine, report
from tests.reliability.dbcheck import assert_derived_cleanly, assert_nothing_lost
from tests.reliability.loadgen import Payloads, run_load
from tests.reliability.relkit import ADMIN_TOKEN, SOAK


def _load(request: pytest.FixtureRequest, line: LiveLine, p: Payloads, seconds: float) -> None:
    stats = run_load(line.server.url, line.devices, p, seconds=seconds)
    figures = stats.summary()
    report(request, f"load {seconds:.0f} s, {len(line.devices)} devices", figures)
    assert not stats.unexpected, stats.unexpected[:5]
    assert stats.connection_errors == 0
    assert not stats.unacked
    assert set(stats.statuses) <= {200, 201}, stats.statuses
    assert len(stats.acked) == len(stats.sent)
    assert_nothing_lost(line.database_url, stats)
    assert_derived_cleanly(line.database_url)
    log = line.server.log_text()
    assert "Traceback" not in log, log[-3000:]
    assert ADMIN_TOKEN not in log
    assert not any(d.key in log for d in line.devices), "a device key was written to the log"


def test_load_short(
    request: pytest.FixtureRequest, live_line: LiveLine, payloads: Payloads
) -> None:
    _load(request, live_line, payloads, 10)


@pytest.mark.slow
@pytest.mark.skipif(not SOAK, reason="60 s load runs only with DEPOT_SOAK=1 (make soak)")
def test_load_soak(request: pytest.FixtureRequest, live_line: LiveLine, payloads: Payloads) -> None:
    _load(request, live_line, payloads, 60)
