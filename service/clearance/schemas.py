"""Dispatcher API bodies."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator


class DecisionIn(BaseModel):
    model_config = ConfigDict(extra="forbid")
    action: Literal["clear", "keep_blocked"]
    reason: Annotated[str, Field(min_length=3, max_length=2000)]

    @field_validator("reason")
    @classmethod
    def _meaningful(cls, reason: str) -> str:
        if len(reason.strip()) < 3:
            raise ValueError("give a reason of at least 3 characters")
        return reason.strip()
