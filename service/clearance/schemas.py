"""Dispatcher API bodies."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict

from service.reasons import Reason


class DecisionIn(BaseModel):
    model_config = ConfigDict(extra="forbid")
    action: Literal["clear", "keep_blocked", "sweep"]
    reason: Reason
