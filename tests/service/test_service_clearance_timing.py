"""Evidence timing and liveness (issue 17): silence is judged by when the server received a
device's events, and only excuses evidence that did not come — never evidence that came.

Every event here reaches the server at its device time unless ``received`` says otherwise
(the server's clock is the test's, ``tests/service/clock.py``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from datetime import datetime, timedelta

import pytest
from fastapi.testclient import TestClient
from sqlalchemy.orm import Session

from ingest.liveness import stale_devices
from tests.conftest import ADMIN
from tests.service.clock import ServerClock, server_clock  # noqa: F401 (fixture)
from tests.service.scenario import T0, Line, jpeg

ARRIVE = T0 + timedelta(minutes=20)
LATE = ARRIVE + timedelta(minutes=10)


@pytest.fixture
def line(client: TestClient, server_clock: ServerClock) -> Line:  # noqa: F811
    return Line.clocked(client, server_clock)


def depart_with(line: Line, *, quiet: tuple[str, ...] = ()) -> int:
    """Every device but ``quiet`` heard of throughout the 10 min before departure (``quiet``:
    last heard of an hour before)."""
    for device in quiet:
        line.post(device, "heartbeat", T0 - timedelta(hours=1))
    line.keep_alive(T0 - timedelta(minutes=10), T0 - timedelta(seconds=20), except_=quiet)
    return line.depart()


def arrive_with(line: Line, *, quiet: tuple[str, ...] = ()) -> dict:
    """Every device but ``quiet`` heard of throughout the journey (the train may have passed
    them then); the tail disc seen; arrival."""
    line.keep_alive(T0 + timedelta(seconds=10), ARRIVE - timedelta(seconds=30), except_=quiet)
    line.snapshot("B-cam", ARRIVE - timedelta(seconds=5), jpeg(disc=True, seed=21))
    return line.arrive(ARRIVE)


def count(line: Line, device: str, axles: int, at: datetime, received: datetime | None = None):
    return line.post(device, "axle_count", at, received=received, section="AB", axles=axles)


def silent_reasons(reasons: list[str]) -> list[str]:
    return [r for r in reasons if "is silent" in r]


def test_departure_count_then_silence_still_proves_the_loss(line: Line) -> None:
    """The issue's case: 32 axles counted at departure, the counter silent after; 28 arrive."""
    depart_with(line, quiet=("A-ac",))
    count(line, "A-ac", 32, T0 + timedelta(seconds=10))  # counted as the train passes the head
    count(line, "B-ac", 28, ARRIVE - timedelta(seconds=20))
    result = arrive_with(line, quiet=("A-ac",))
    assert result["verdict"] == "incomplete", result
    assert any("28 axles arrived of 32 that departed (4 missing)" in r for r in result["reasons"])
    assert not silent_reasons(result["reasons"])
    assert line.section()["state"] == "alarm"


@dataclass(frozen=True)
class Timing:
    """One combination of when a device spoke; ``late`` is posted after the first decision."""

    name: str
    before_arrival: Callable[[Line], None]
    quiet: tuple[str, ...]
    verdict: str
    silent: list[str]
    late: Callable[[Line], None] | None = None
    late_verdict: str | None = None


def _both_counts(line: Line) -> None:
    count(line, "A-ac", 32, T0 - timedelta(seconds=15))
    # B-ac counts the train entering, 2 min before arrival, and is not heard of again.
    count(line, "B-ac", 28, ARRIVE - timedelta(minutes=2))


def _departure_only(line: Line) -> None:
    count(line, "A-ac", 32, T0 - timedelta(seconds=15))


def _late_arrival_count(line: Line) -> None:
    # The counter's own clock puts the count before arrival; the server gets it 10 min late.
    count(line, "B-ac", 28, ARRIVE - timedelta(seconds=20), received=LATE)


def _clock_behind(line: Line) -> None:
    _departure_only(line)
    # B-ir's clock is 3 h behind, but the server hears from it each 30 s while the train passes.
    for k in range(20):
        received = ARRIVE - timedelta(minutes=10) + timedelta(seconds=30 * k)
        line.post("B-ir", "heartbeat", received - timedelta(hours=3), received=received)


TIMINGS = [
    Timing("reported then silent", _both_counts, ("B-ac",), "incomplete", []),
    Timing("silent throughout", _departure_only, ("B-ac",), "undetermined", ["B-ac"]),
    Timing(
        "late report",
        _departure_only,
        ("B-ac",),
        "undetermined",
        ["B-ac"],
        late=_late_arrival_count,
        late_verdict="incomplete",
    ),
    Timing("alive, nothing to report", _departure_only, (), "complete", []),
    Timing("device clock behind, heard in time", _clock_behind, ("B-ir",), "complete", []),
]


@pytest.mark.parametrize("timing", TIMINGS, ids=[t.name for t in TIMINGS])
def test_evidence_timing(line: Line, timing: Timing) -> None:
    depart_with(line)
    timing.before_arrival(line)
    result = arrive_with(line, quiet=timing.quiet)
    assert result["verdict"] == timing.verdict, result
    assert [r.split()[1] for r in silent_reasons(result["reasons"])] == timing.silent
    if timing.late is None:
        return
    timing.late(line)
    run = line.section()["run"]
    assert run["decision"]["verdict"] == timing.late_verdict, run
    assert not silent_reasons(run["decision"]["reasons"])  # the evidence came after all
    assert "(4 missing)" in " ".join(run["decision"]["reasons"])
    assert run["evidence"]["stale_devices"] == []


def test_a_decommissioned_device_is_not_silent(
    session: Session,
    line: Line,
    server_clock: ServerClock,  # noqa: F811
) -> None:
    depart_with(line)
    server_clock.set(T0 + timedelta(minutes=5))
    answer = line.client.post("/api/v1/devices/B-ir/decommission", headers=ADMIN)
    assert answer.status_code == 200, answer.text
    result = arrive_with(line, quiet=("B-ir",))
    assert result["verdict"] == "complete", result
    device = line.client.get("/api/v1/devices/B-ir", headers=ADMIN).json()
    assert device["stale"] is None  # decommissioned: no heartbeat is expected any more
    listed = [d.id for d in stale_devices(session, ARRIVE + timedelta(minutes=5))]
    assert "B-ir" not in listed and "B-ac" in listed  # the screen's list, by the same rule


def test_last_seen_is_when_the_server_received(line: Line, server_clock: ServerClock) -> None:  # noqa: F811
    # 4 min ahead (within the allowed skew) and 3 h behind: both received at T0.
    line.post("B-ir", "heartbeat", T0 + timedelta(minutes=4), received=T0)
    line.post("B-wm", "heartbeat", T0 - timedelta(hours=3), received=T0)
    for device in ("B-ir", "B-wm"):
        seen = line.client.get(f"/api/v1/devices/{device}", headers=ADMIN).json()
        assert seen["last_seen_at"] == "2026-11-23T10:00:00Z", seen


def test_stale_is_filled_in_from_the_heartbeat_rule(line: Line, server_clock: ServerClock) -> None:  # noqa: F811
    line.post("B-ir", "heartbeat", T0)
    server_clock.set(T0 + timedelta(seconds=30))
    assert line.client.get("/api/v1/devices/B-ir", headers=ADMIN).json()["stale"] is False
    server_clock.set(T0 + timedelta(minutes=2))  # past DEPOT_HEARTBEAT_S (60 s)
    assert line.client.get("/api/v1/devices/B-ir", headers=ADMIN).json()["stale"] is True
    listed = {d["id"]: d["stale"] for d in line.client.get("/api/v1/devices", headers=ADMIN).json()}
    assert listed["B-ir"] is True and listed["A-ac"] is True  # A-ac never spoke at all
    line.post("A-ac", "heartbeat", T0 + timedelta(minutes=2))
    listed = {d["id"]: d["stale"] for d in line.client.get("/api/v1/devices", headers=ADMIN).json()}
    assert listed["A-ac"] is False and None not in listed.values()
