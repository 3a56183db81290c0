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
    verdict: str = Field(description="complete, incomplete or undetermined (the rules' verdict)")
    reasons: list[str]
    auto: bool | None = Field(description="decided by the rules (true) or by a person")
    action: str | None = Field(
        default=None,
        description="the latest action taken on the run: clear, keep_blocked, sweep, or"
        " cleared_by_sweep (depot's own, when a sweep run proved the section empty); null"
        " while nobody has acted",
    )
    actor: str | None = Field(default=None, description="who took that action")
    acted_at: Instant | None = Field(default=None, description="when that action was recorded")


class RunOut(Answer):
    id: int
    section: str
    train: str
    status: str = Field(
        description="running, arrived, conflict (departed into a section that was not cleared"
        " and waits behind its current run, arrived or not: see arrived_at), overtaken"
        " (its arrival never came, a train behind it arrived or its section fell silent, and a"
        " dispatcher released it), explained (the run of an arrival nobody saw enter, acted"
        " on by a person, whose departure came later and took the arrival), or fault (no train:"
        " an event naming the section could not be processed — its derive_error — and a person"
        " must look; conflict holds the words, and a dispatcher decides it like any run)"
    )
    conflict: str | None = Field(
        default=None,
        description="why the run departed into a section that was not cleared (a person must"
        " look at such a run; it is never decided complete by itself)",
    )
    departure_seen: bool = Field(
        default=True,
        description="false for the run of an arrival out of a section nobody saw a train enter"
        " (no departure reached depot): its departed_at is the arrival's time standing in, and"
        " a person must look at it",
    )
    from_station: str
    to_station: str
    departed_at: Instant | None = Field(description="the interlocking's (device) time")
    arrived_at: Instant | None = Field(description="the interlocking's (device) time")
    sweep: bool = Field(
        default=False,
        description="a sweep run: the train sent through a section awaiting a sweep to prove"
        " it empty (no conflict alarm for it)",
    )
    sweep_of: int | None = Field(default=None, description="for a sweep run: the run it sweeps")
    cleared_by: int | None = Field(
        default=None,
        description="the sweep run whose complete arrival cleared this run (while it stays"
        " complete)",
    )
    eot_unit: int | None = Field(
        default=None, description="the EOT unit address armed on the train (train_departed)"
    )
    evidence: dict[str, Any] | None = Field(
        description="the evidence as gathered for the latest decision; ``stale_devices``"
        " lists the devices whose evidence is missing because the server heard nothing from"
        " them for longer than DEPOT_HEARTBEAT_S while the train may have passed them, and"
        " ``silent_while_passing`` when (``heard_at``: last heard; ``silent_until``: heard"
        " again, or the end of the window when ``ongoing``); ``unheard_devices``: arrival-end"
        " readers and counters alive throughout that reported nothing; ``zero_axle_counts``:"
        " counters that reported 0 axles (no count)"
    )
    decision: DecisionOut | None
    overrides: list[AuditOut]
    revision: str = Field(
        description="what the run shows now (verdict, section state, evidence, actions), as"
        " one opaque tag: also the ETag of GET /runs/{id}. Send it back with a decision"
        " (If-Match or seen) and the decision is refused (409) if the run has changed since"
    )


class SectionOut(Answer):
    id: str
    state: str
    mode: str
    from_station: str
    to_station: str
    state_since: Instant | None
    last_run_id: int | None
    conflict_runs: list[int]
    fault_runs: list[int] = Field(
        default_factory=list,
        description="fault runs nobody has decided yet that wait behind the current run:"
        " events naming the section that could not be processed (the section is not free"
        " until a dispatcher has decided each)",
    )
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
