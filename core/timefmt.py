"""Times as people read them: one format, in the dispatcher's zone, the zone always shown.

The JSON API keeps ISO-8601 UTC with ``Z`` (``core.schemas.Instant``); screens, notices and
messages for people use these functions instead, so that every page says the same time the
same way: ``19:54:11 EET`` or ``2026-11-23 19:54:11 EET`` — whole seconds, never
microseconds, in ``DEPOT_TIME_ZONE`` (default ``UTC``).
"""

from __future__ import annotations

from datetime import datetime, timedelta
from functools import lru_cache
from zoneinfo import ZoneInfo

from core.settings import get_settings

NOTHING = "—"  # what is shown for a time that is not known (never seen, not yet arrived)


@lru_cache(maxsize=8)
def _zone(name: str) -> ZoneInfo:
    return ZoneInfo(name)


def local(at: datetime) -> datetime:
    """``at`` in the dispatcher's zone, to the whole second; naive times are refused."""
    if at.tzinfo is None:
        raise ValueError("naive datetime given; times must carry an offset")
    return at.astimezone(_zone(get_settings().time_zone)).replace(microsecond=0)


def clock_time(at: datetime | None) -> str:
    """``HH:MM:SS ZONE`` (for today's events and "updated at"), or a dash."""
    return NOTHING if at is None else local(at).strftime("%H:%M:%S %Z")


def date_time(at: datetime | None) -> str:
    """``YYYY-MM-DD HH:MM:SS ZONE`` (for the audit and anything older), or a dash."""
    return NOTHING if at is None else local(at).strftime("%Y-%m-%d %H:%M:%S %Z")


def elapsed(since: datetime, now: datetime) -> str:
    """How long from ``since`` to ``now`` in words: ``under 1 min``, ``54 min``, ``2 h 05 min``
    (for "in alarm for …"); a ``since`` in the future reads as under a minute."""
    minutes = max(now - since, timedelta(0)) // timedelta(minutes=1)
    if minutes < 1:
        return "under 1 min"
    hours, minutes = divmod(minutes, 60)
    return f"{minutes} min" if hours == 0 else f"{hours} h {minutes:02d} min"
