"""The reason a person gives for an override: required, meaningful, kept verbatim in the audit."""

from __future__ import annotations

from typing import Annotated

from pydantic import AfterValidator, Field

MIN_LENGTH = 3


def meaningful(reason: str) -> str | None:
    """The reason as it will be kept, or None when it says nothing (one rule: API and forms)."""
    kept = reason.strip()
    return kept if len(kept) >= MIN_LENGTH else None


def _required(reason: str) -> str:
    kept = meaningful(reason)
    if kept is None:
        raise ValueError(f"give a reason of at least {MIN_LENGTH} characters")
    return kept


Reason = Annotated[str, Field(min_length=MIN_LENGTH, max_length=2000), AfterValidator(_required)]
