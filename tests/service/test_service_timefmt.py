"""One time format for people (issue 17): the dispatcher's zone (``DEPOT_TIME_ZONE``, default
UTC) shown, whole seconds, never microseconds."""

from __future__ import annotations

from collections.abc import Iterator
from datetime import UTC, datetime

import pytest
from pydantic import ValidationError

from core import timefmt
from core.settings import Settings, get_settings

EVENING = datetime(2026, 11, 23, 17, 54, 11, 987654, tzinfo=UTC)
SUMMER = datetime(2026, 7, 1, 6, 5, 4, tzinfo=UTC)


@pytest.fixture
def zone(monkeypatch: pytest.MonkeyPatch) -> Iterator[object]:
    def use(name: str) -> None:
        monkeypatch.setenv("DEPOT_TIME_ZONE", name)
        get_settings.cache_clear()

    yield use
    monkeypatch.delenv("DEPOT_TIME_ZONE", raising=False)
    get_settings.cache_clear()


def test_utc_by_default(zone: object) -> None:
    assert Settings().time_zone == "UTC"
    assert timefmt.clock_time(EVENING) == "17:54:11 UTC"
    assert timefmt.date_time(EVENING) == "2026-11-23 17:54:11 UTC"


def test_the_dispatchers_zone_is_shown(zone: object) -> None:
    zone("Europe/Kyiv")  # type: ignore[operator]
    assert timefmt.clock_time(EVENING) == "19:54:11 EET"
    assert timefmt.date_time(EVENING) == "2026-11-23 19:54:11 EET"
    assert timefmt.date_time(SUMMER) == "2026-07-01 09:05:04 EEST"  # summer time
    naive_is_refused = datetime(2026, 11, 23, 17, 54, 11)
    with pytest.raises(ValueError, match="offset"):
        timefmt.clock_time(naive_is_refused)


def test_nothing_is_a_dash_and_durations_are_words() -> None:
    assert timefmt.clock_time(None) == "—" and timefmt.date_time(None) == "—"
    since = datetime(2026, 11, 23, 17, 0, tzinfo=UTC)
    assert timefmt.elapsed(since, EVENING) == "54 min"
    assert timefmt.elapsed(since, datetime(2026, 11, 23, 19, 5, tzinfo=UTC)) == "2 h 05 min"
    assert timefmt.elapsed(since, datetime(2026, 11, 23, 17, 0, 40, tzinfo=UTC)) == "under 1 min"


def test_an_unknown_zone_is_refused_with_the_fix(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("DEPOT_TIME_ZONE", "Europe/Atlantis")
    with pytest.raises(ValidationError, match="IANA time zone"):
        Settings()


def test_one_set_of_conventions_for_every_screen(zone: object) -> None:
    """The review screens use these functions too: the API's ISO text is read, days are
    ``3 d 4 h``, nothing known is a dash (never an empty text), a naive text is refused."""
    zone("Europe/Kyiv")  # type: ignore[operator]
    assert timefmt.date_time("2026-11-23T17:54:11.250Z") == "2026-11-23 19:54:11 EET"
    assert timefmt.clock_time("2026-11-23T17:54:11Z") == "19:54:11 EET"
    assert timefmt.date_time("") == "—"
    since = datetime(2026, 11, 20, 13, 30, tzinfo=UTC)
    assert timefmt.elapsed(since, EVENING) == "3 d 4 h"
    assert timefmt.elapsed("2026-11-22T17:54:11Z", EVENING) == "1 d 0 h"
    assert timefmt.elapsed(since, datetime(2026, 11, 21, 13, 29, tzinfo=UTC)) == "23 h 59 min"
    with pytest.raises(ValueError, match="offset"):
        timefmt.date_time("2026-11-23T17:54:11")


def test_the_review_screens_have_no_formatter_of_their_own() -> None:
    import importlib.util

    assert importlib.util.find_spec("service.review.timefmt") is None
