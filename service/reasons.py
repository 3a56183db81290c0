"""The reason a person gives for an override: required, meaningful, kept verbatim in the audit."""

from __future__ import annotations

from typing import Annotated

from pydantic import AfterValidator, Field

MIN_LENGTH = 3
# The words a person reads when a reason is refused (API, review screen, fleet screen).
RULE = f"a reason of at least {MIN_LENGTH} letters or digits"


def meaningful(reason: str) -> str | None:
    """The reason as it will be kept, or None when it says nothing (one rule: API and forms).

    Punctuation alone (``"..."``) says nothing: at least ``MIN_LENGTH`` letters or digits, in
    any alphabet."""
    kept = reason.strip()
    return kept if sum(ch.isalnum() for ch in kept) >= MIN_LENGTH else None


def _required(reason: str) -> str:
    kept = meaningful(reason)
    if kept is None:
        raise ValueError(f"give {RULE}")
    return kept


# The length check is the validator's, so that every refusal names the same rule.
Reason = Annotated[str, Field(min_length=1, max_length=2000), AfterValidator(_required)]
