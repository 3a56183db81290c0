"""Field types of device events (protocol v1): device times, identifiers and integers.

One place for the rules every event kind's fields share, so :mod:`ingest.schemas` holds
the event kinds themselves.
"""

from __future__ import annotations

import re
from datetime import UTC, datetime, timedelta, timezone
from typing import Annotated

from pydantic import AfterValidator, AwareDatetime, BeforeValidator, Field

__all__ = [
    "EARLIEST",
    "LATEST",
    "CarId",
    "DeviceTime",
    "EventId",
    "Integer",
    "Microseconds",
    "SectionId",
    "TrainNumber",
]

EARLIEST = datetime(2000, 1, 1, tzinfo=UTC)
LATEST = datetime(2100, 1, 1, tzinfo=UTC)
# The world's time zones run from UTC-12:00 (Baker Island) to UTC+14:00 (Line Islands). A
# device time outside them has a misconfigured zone (and PostgreSQL stores offsets only up to
# ±15:59: such a time once failed in the database, taking its batch with it).
WESTMOST_OFFSET = timedelta(hours=-12)
EASTMOST_OFFSET = timedelta(hours=14)


def _plausible(at: datetime) -> datetime:
    # The parsed time's offset as the standard library's ``timezone`` instead of pydantic's
    # own tzinfo, which every later comparison or conversion calls back into (about 1 µs each,
    # several per event of a batch); ``datetime.timezone`` is handled in C. The instant, its
    # offset and its text (isoformat, JSON) are unchanged.
    offset = at.utcoffset()
    if offset is not None and not WESTMOST_OFFSET <= offset <= EASTMOST_OFFSET:
        raise ValueError(
            "the UTC offset must be between -12:00 and +14:00, as every time zone's"
            " (check the device's time zone setting)"
        )
    at = at.replace(tzinfo=UTC if not offset else timezone(offset))
    # A device clock outside this range is broken; its times would poison every computation.
    if not EARLIEST <= at < LATEST:
        raise ValueError("time must be between 2000-01-01 and 2100-01-01 (check the device clock)")
    return at


def _integral(value: object) -> object:
    """protocol.md: number spelling does not matter, so 10.0 is the integer 10; anything else
    (true, "12", 12.5) is left for strict validation to refuse."""
    if isinstance(value, float) and value.is_integer():
        return int(value)
    return value


# An integer field: a JSON number with no fraction; never a boolean or a string.
Integer = Annotated[int, BeforeValidator(_integral)]


def _iso_text(value: object) -> object:
    """protocol.md: "times in ISO 8601 with offset". Pydantic's lax datetime would also read a
    Unix time, as a number or as digits in a string; a device sending one is refused."""
    if isinstance(value, bool | int | float) or (
        isinstance(value, str) and not _ISO_DATE.match(value)
    ):
        raise ValueError("a time must be ISO 8601 text with an offset, e.g. 2026-11-23T10:15:00Z")
    return value


_ISO_DATE = re.compile(r"\d{4}-\d{2}-\d{2}[Tt ]", re.ASCII)
# Times come as ISO-8601 text, so they alone are parsed (every other field is strict).
DeviceTime = Annotated[
    AwareDatetime, Field(strict=False), BeforeValidator(_iso_text), AfterValidator(_plausible)
]
EventId = Annotated[str, Field(min_length=1, max_length=64, pattern=r"^[\x21-\x7e]+$")]
SectionId = Annotated[str, Field(min_length=1, max_length=32)]
TrainNumber = Annotated[str, Field(min_length=1, max_length=32)]
CarId = Annotated[str, Field(min_length=1, max_length=32)]
Microseconds = Annotated[float, Field(ge=0, allow_inf_nan=False)]
