"""One time format for the screens: the dispatcher's time zone, seconds, the zone shown.

Local to the review screen until a shared formatter exists (``DEPOT_TIME_ZONE``, default UTC);
the lead unifies it with the server side's.
"""

from __future__ import annotations

import os
from datetime import UTC, datetime
from zoneinfo import ZoneInfo, ZoneInfoNotFoundError

from core.settings import get_settings


def zone() -> ZoneInfo:
    """The dispatcher's zone: the setting ``time_zone`` when it exists, else ``DEPOT_TIME_ZONE``."""
    name = str(getattr(get_settings(), "time_zone", "") or os.environ.get("DEPOT_TIME_ZONE", ""))
    try:
        return ZoneInfo(name or "UTC")
    except (ZoneInfoNotFoundError, ValueError):
        return ZoneInfo("UTC")


def _local(value: datetime | str) -> datetime:
    at = datetime.fromisoformat(value) if isinstance(value, str) else value
    if at.tzinfo is None:  # the database keeps UTC
        at = at.replace(tzinfo=UTC)
    return at.astimezone(zone()).replace(microsecond=0)


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
