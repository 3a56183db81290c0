"""Dispatcher API bodies."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from core.schemas import StrictModel
from service.reasons import Reason


class DecisionIn(StrictModel):
    action: Literal["clear", "keep_blocked", "sweep"]
    reason: Reason
    seen: str | None = Field(
        default=None,
        max_length=200,
        description="the run's revision the decision is based on (RunOut.revision, the ETag of"
        " GET /runs/{id}; or send If-Match): a run changed since is refused (409) and nothing"
        " is recorded. Optional, but a client should always send it",
    )
