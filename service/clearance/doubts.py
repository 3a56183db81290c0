"""The run's own doubts, derived from the run (not from its evidence), and how they rank with
the rules' reasons: every re-decision — late evidence, replay — keeps them."""

from __future__ import annotations

from datetime import datetime

from core.database import utcnow
from core.schemas import format_instant
from service.clearance.models import Run
from service.clearance.rules import Decision, Verdict


def not_ahead(at: datetime | None, received: datetime | None) -> datetime:
    """A state's time from a device's time, never later than the server's now (``received``:
    when the server got the event; a device clock ahead must not date a state in the future).
    """
    now = received or utcnow()
    return now if at is None else min(at, now)


def train_contradictions(run: Run) -> list[str]:
    """The arrival reported another train number than the departure: which train is in the
    section is in doubt, so the run is never ``complete`` without a person. Derived from the
    run (the arrival's number is stored) so that every re-decision — late evidence, replay —
    keeps it, as the dispatcher must keep seeing it."""
    if run.arrival_train is None or run.arrival_train == run.train:
        return []
    return [f"arrival reported train {run.arrival_train}, departure train {run.train}"]


def time_contradictions(run: Run) -> list[str]:
    """An arrival dated before its own departure: one of the two clocks is wrong, so no time
    window of the run can be trusted. Kept (201, stored, never dropped) but never ``complete``:
    derived from the run so that every re-decision keeps it."""
    if run.arrived_at is None or run.arrived_at >= run.departed_at:
        return []
    return [
        f"the arrival is dated {format_instant(run.arrived_at)}, before the departure at"
        f" {format_instant(run.departed_at)}: a device clock is wrong; a person must look"
    ]


def blocking_first(decision: Decision, notes: list[str]) -> tuple[Verdict, list[str]]:
    """The verdict with the run's own doubts (``notes``), and the reasons ordered so that the
    first one — the queue's headline — is what blocks: a loss, then the run's own doubts (two
    trains in the section, a wrong clock or number), then the evidence's, and what agrees
    last (a train-number mismatch is never shown behind "axle counts agree")."""
    if decision.verdict == "complete" and notes:
        # a mismatched train number or clock, a conflict: a person's eyes are needed
        return "undetermined", [*notes, *decision.reasons]
    if decision.verdict == "undetermined":
        # a second train in the section, a wrong clock or number outweigh a missing photo
        return decision.verdict, [*notes, *decision.reasons]
    return decision.verdict, [*decision.reasons, *notes]
