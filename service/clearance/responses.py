"""Typed answers of the dispatcher API (the OpenAPI document shows every field).

Fields that features add as they grow are allowed through (``extra="allow"``) so that an
answer is never cut short; the documented fields are the contract.
"""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ConfigDict, Field

from core.schemas import Instant


class Answer(BaseModel):
    model_config = ConfigDict(extra="allow")


class AuditOut(Answer):
    id: int
    run_id: int | None
    section: str
    action: str = Field(description="clear, keep_blocked, … — what the person did")
    reason: str
    actor: str
    actor_role: str
    recorded_at: Instant
    state_before: str | None
    state_after: str | None
    evidence: dict[str, Any] | None = Field(description="the evidence as it stood then")


class DecisionOut(Answer):
    verdict: str = Field(description="complete, incomplete or undetermined")
    reasons: list[str]
    auto: bool | None = Field(description="decided by the rules (true) or by a person")


class RunOut(Answer):
    id: int
    section: str
    train: str
    status: str = Field(description="running, arrived or conflict")
    from_station: str
    to_station: str
    departed_at: Instant | None
    arrived_at: Instant | None
    evidence: dict[str, Any] | None
    decision: DecisionOut | None
    overrides: list[AuditOut]


class SectionOut(Answer):
    id: str
    state: str
    mode: str
    from_station: str
    to_station: str
    state_since: Instant | None
    last_run_id: int | None
    conflict_runs: list[int]
    run: RunOut | None


class RunsPage(Answer):
    items: list[RunOut]
    next_cursor: int | None = Field(description="pass as ?cursor= for the next (older) page")


class DecisionAnswer(Answer):
    audit: AuditOut | None
    section: str
    state: str = Field(description="the section's state after the decision")


class SnapshotMetaOut(Answer):
    id: int
    device: str
    section: str
    run_id: int | None
    side: str | None
    occurred_at: Instant
    sha256: str
    width: int
    height: int
    verdict: str | None
    score: float | None
    detection: dict[str, Any] | None


class WheelMarkingOut(Answer):
    id: int
    device: str
    code: int
    state: str
    written: list[Any]
    faults: list[str]
    occurred_at: Instant
