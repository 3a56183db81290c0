"""Crash: SIGKILL the whole server during load, restart it, let the devices retry.

Every acknowledged event must be stored exactly once, and the derived state the live service
built must equal what ``depot replay`` rebuilds from the raw events.
"""

from __future__ import annotations

import threading
import time

import pytest

from tests.reliability.conftest import LiveLine, report
from tests.reliability.dbcheck import (
    assert_derived_cleanly,
    assert_nothing_lost,
    derived_state,
)
from tests.reliability.loadgen import Payloads, Stats, run_load
from tests.reliability.relkit import SOAK, run_depot


def _load_with_kills(line: LiveLine, p: Payloads, seconds: float, kills: int) -> Stats:
    result: dict[str, Stats] = {}
    loader = threading.Thread(
        target=lambda: result.update(
            stats=run_load(line.server.url, line.devices, p, seconds=seconds)
        ),
        daemon=True,
    )
    loader.start()
    for k in range(kills):
        time.sleep(seconds / (kills + 1) if k == 0 else seconds / (kills + 1) - 1)
        line.server.kill()
        time.sleep(1.0)  # devices meet a dead address for a while
        line.server.start()
    loader.join(timeout=seconds + 240)
    assert not loader.is_alive(), "the simulated devices did not finish"
    return result["stats"]


def _crash(
    request: pytest.FixtureRequest, line: LiveLine, p: Payloads, seconds: float, kills: int
) -> None:
    stats = _load_with_kills(line, p, seconds, kills)
    line.server.stop()
    live = derived_state(line.database_url)
    figures = {
        **stats.summary(),
        "kills": kills,
        "retries_answered_200": stats.statuses.get(200, 0),
    }
    report(request, f"crash: {kills} SIGKILL during {seconds:.0f} s load", figures)
    assert stats.connection_errors > 0, "the kill was not felt by any device"
    assert not stats.unexpected, stats.unexpected[:5]
    assert not stats.unacked, f"{len(stats.unacked)} events never acknowledged"
    assert len(stats.acked) == len(stats.sent)
    assert_nothing_lost(line.database_url, stats)
    done = run_depot(line.server.env, "replay")
    rebuilt = derived_state(line.database_url)
    for table in live:
        assert rebuilt[table] == live[table], f"{table}: live state differs from depot replay"
    assert done.returncode == 0, done.stdout + done.stderr
    assert_derived_cleanly(line.database_url)


def test_sigkill_during_load_loses_nothing(
    request: pytest.FixtureRequest, live_line: LiveLine, payloads: Payloads
) -> None:
    _crash(request, live_line, payloads, 8, 1)


@pytest.mark.slow
@pytest.mark.skipif(not SOAK, reason="60 s load with 3 kills runs only with DEPOT_SOAK=1")
def test_repeated_sigkill_during_soak(
    request: pytest.FixtureRequest, live_line: LiveLine, payloads: Payloads
) -> None:
    _crash(request, live_line, payloads, 60, 3)
