"""What every HTTP body shares: strict request models and one way to write an instant.

Every time depot answers with is an ISO-8601 instant in UTC written with ``Z``
(``2026-11-30T17:54:11.250Z``: milliseconds when there are any, never microseconds),
whatever the database driver or the device sent.
"""

from __future__ import annotations

from datetime import UTC, datetime
from typing import Annotated, Any

from pydantic import BaseModel, ConfigDict, PlainSerializer, field_validator
from pydantic_core import PydanticCustomError


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
    """A request body: unknown fields are refused (422), so a misspelt field is never ignored;
    nor is a text holding U+0000 taken (PostgreSQL's text cannot hold it)."""

    model_config = ConfigDict(extra="forbid")

    @field_validator("*", mode="after")
    @classmethod
    def _text_without_nul(cls, value: Any) -> Any:
        # An independent trial: a dispatcher's reason "a\u0000bc" was answered 422 "a value
        # cannot be stored or looked up" by the database, naming no field. Refused here, for
        # every person's body (reasons, station and person names, fleet texts), by field.
        if holds_nul(value):
            raise nul_character()
        return value


def nul_character() -> PydanticCustomError:
    """The refusal of a text holding U+0000, one wording for people's bodies and device events."""
    return PydanticCustomError(
        "nul_character",
        "holds a NUL character (U+0000), which cannot be stored; send the text without it",
    )


def holds_nul(value: Any) -> bool:
    """Whether a field's value (text, or a list or mapping of texts, nested) holds U+0000."""
    if isinstance(value, str):
        return "\x00" in value
    if isinstance(value, dict):
        return any(holds_nul(k) or holds_nul(v) for k, v in value.items())
    if isinstance(value, list | tuple):
        return any(holds_nul(item) for item in value)
    if isinstance(value, BaseModel):
        return any(holds_nul(getattr(value, name)) for name in type(value).model_fields)
    return False
