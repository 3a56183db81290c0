"""Times as people read them: one format, in the dispatcher's zone, the zone always shown.

The JSON API keeps ISO-8601 UTC with ``Z`` (``core.schemas.Instant``); screens, notices and
messages for people use these functions instead (the review screens through template filters),
so that every page says the same time the same way. The conventions, in one place:

- an instant: ``19:54:11 EET`` (:func:`clock_time`, for "updated at") or
  ``2026-11-23 19:54:11 EET`` (:func:`date_time`, for everything else) — whole seconds, never
  microseconds, in ``DEPOT_TIME_ZONE`` (default ``UTC``), the zone's abbreviation always shown;
- a time that is not known (never seen, not yet arrived): ``—`` (:data:`NOTHING`), never an
  empty text;
- how long: ``under 1 min``, ``54 min``, ``2 h 05 min``, ``3 d 4 h`` (:func:`elapsed`).

Either an aware ``datetime`` or the API's ISO-8601 text (``2026-11-23T17:54:11Z``) is taken;
a time without an offset is refused rather than guessed.
"""

from __future__ import annotations

from datetime import datetime, timedelta
from functools import lru_cache
from zoneinfo import ZoneInfo

from core.settings import get_settings

NOTHING = "—"  # what is shown for a time that is not known (never seen, not yet arrived)
MINUTE = timedelta(minutes=1)


@lru_cache(maxsize=8)
def _zone(name: str) -> ZoneInfo:
    return ZoneInfo(name)


def instant(at: datetime | str) -> datetime:
    """``at`` as an aware datetime: the API's ISO-8601 text is parsed; naive times are refused."""
    value = datetime.fromisoformat(at) if isinstance(at, str) else at
    if value.tzinfo is None:
        raise ValueError(f"naive time {at!r} given; times must carry an offset")
    return value


def local(at: datetime | str) -> datetime:
    """``at`` in the dispatcher's zone, to the whole second; naive times are refused."""
    return instant(at).astimezone(_zone(get_settings().time_zone)).replace(microsecond=0)


def _shown(at: datetime | str | None, pattern: str) -> str:
    if at is None or at == "":
        return NOTHING
    return local(at).strftime(pattern)


def clock_time(at: datetime | str | None) -> str:
    """``HH:MM:SS ZONE`` (for today's events and "updated at"), or a dash."""
    return _shown(at, "%H:%M:%S %Z")


def date_time(at: datetime | str | None) -> str:
    """``YYYY-MM-DD HH:MM:SS ZONE`` (for the audit and anything older), or a dash."""
    return _shown(at, "%Y-%m-%d %H:%M:%S %Z")


def elapsed(since: datetime | str, now: datetime) -> str:
    """How long from ``since`` to ``now`` in words: ``under 1 min``, ``54 min``, ``2 h 05 min``,
    ``3 d 4 h`` (for "in alarm for …"); a ``since`` in the future reads as under a minute."""
    minutes = max(now - instant(since), timedelta(0)) // MINUTE
    if minutes < 1:
        return "under 1 min"
    hours, minutes = divmod(minutes, 60)
    if hours == 0:
        return f"{minutes} min"
    if hours < 24:
        return f"{hours} h {minutes:02d} min"
    days, hours = divmod(hours, 24)
    return f"{days} d {hours} h"
