"""One time format for the screens: the dispatcher's time zone, seconds, the zone shown.

The zone rule is :func:`core.timefmt.local` (``DEPOT_TIME_ZONE``); this module only adds what
templates need: strings from JSON answers, an empty text for "no time", durations with days.
"""

from __future__ import annotations

from datetime import UTC, datetime

from core.timefmt import local


def _local(value: datetime | str) -> datetime:
    at = datetime.fromisoformat(value) if isinstance(value, str) else value
    if at.tzinfo is None:  # the database keeps UTC
        at = at.replace(tzinfo=UTC)
    return local(at)


def when(value: datetime | str | None) -> str:
    """``2026-11-23 10:00:00 UTC`` (in the dispatcher's zone, its abbreviation shown)."""
    if value is None or value == "":
        return ""
    at = _local(value)
    return f"{at:%Y-%m-%d %H:%M:%S} {at.tzname()}"


def clock(value: datetime | str | None) -> str:
    """``10:00:00`` in the dispatcher's zone (next to a ``when`` that names the zone)."""
    return "" if value is None or value == "" else f"{_local(value):%H:%M:%S}"


def zone_name(value: datetime) -> str:
    return _local(value).tzname() or "UTC"


def duration(seconds: float) -> str:
    """``12 min``, ``2 h 05 min``, ``3 d 4 h``: how long a section has been in its state."""
    minutes = max(0, int(seconds // 60))
    if minutes < 60:
        return f"{minutes} min"
    hours, minutes = divmod(minutes, 60)
    if hours < 24:
        return f"{hours} h {minutes:02d} min"
    days, hours = divmod(hours, 24)
    return f"{days} d {hours} h"
