"""The reason a person gives for an override: required, meaningful, kept verbatim in the audit."""

from __future__ import annotations

from typing import Annotated

from pydantic import AfterValidator, Field


def _meaningful(reason: str) -> str:
    if len(reason.strip()) < 3:
        raise ValueError("give a reason of at least 3 characters")
    return reason.strip()


Reason = Annotated[str, Field(min_length=3, max_length=2000), AfterValidator(_meaningful)]
