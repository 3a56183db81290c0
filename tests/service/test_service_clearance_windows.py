"""The departure-side attachment window, as a pure function (``attribution.place``)."""

from __future__ import annotations

from datetime import UTC, datetime, timedelta

import pytest

from service.clearance.attribution import WINDOWS, place
from service.clearance.models import Run

DEPARTED = datetime(2026, 11, 23, 10, 0, tzinfo=UTC)


def _running() -> Run:
    return Run(
        id=7,
        section="AB",
        train="2043",
        from_station="A",
        to_station="B",
        departed_at=DEPARTED,
        arrived_at=None,
        status="running",
    )


def test_the_adoption_window_is_seconds_and_the_doubt_window_minutes() -> None:
    assert WINDOWS.adopt_before_departure <= timedelta(seconds=60)
    assert WINDOWS.before_departure >= timedelta(minutes=10)


@pytest.mark.parametrize("before", [timedelta(seconds=0), timedelta(seconds=60)])
def test_evidence_just_before_the_departure_is_the_runs(before: timedelta) -> None:
    run = _running()
    placed = place([run], DEPARTED - before, "A")
    assert placed.owner is run and placed.certain


@pytest.mark.parametrize("before", [timedelta(seconds=61), timedelta(minutes=3)])
def test_evidence_minutes_before_the_departure_is_only_a_doubt(before: timedelta) -> None:
    run = _running()
    placed = place([run], DEPARTED - before, "A")
    assert placed.owner is None
    assert placed.rivals == (run,) and not placed.certain
