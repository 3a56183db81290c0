"""What every HTTP body shares: strict request models and one way to write an instant.

Every time depot answers with is an ISO-8601 instant in UTC written with ``Z``
(``2026-11-30T17:54:11.250Z``: milliseconds when there are any, never microseconds),
whatever the database driver or the device sent.
"""

from __future__ import annotations

from datetime import UTC, datetime
from typing import Annotated

from pydantic import BaseModel, ConfigDict, PlainSerializer


def format_instant(value: datetime) -> str:
    """``value`` as ISO-8601 UTC with ``Z`` (naive values are taken as UTC)."""
    at = value.replace(tzinfo=UTC) if value.tzinfo is None else value.astimezone(UTC)
    text = at.isoformat(timespec="milliseconds" if at.microsecond else "seconds")
    return text.replace("+00:00", "Z")


def format_optional_instant(value: datetime | None) -> str | None:
    return None if value is None else format_instant(value)


# A datetime field of a response model: serialised by `format_instant` in JSON.
Instant = Annotated[datetime, PlainSerializer(format_instant, return_type=str, when_used="json")]


class StrictModel(BaseModel):
    """A request body: unknown fields are refused (422), so a misspelt field is never ignored."""

    model_config = ConfigDict(extra="forbid")
