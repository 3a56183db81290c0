"""Clear after a sweep train: the swept run is recorded as cleared by the sweep run while (and
only while) the sweep run is decided complete (clearance.md)."""

from __future__ import annotations

from sqlalchemy import select
from sqlalchemy.orm import Session

from core.auth import Principal
from core.database import utcnow
from core.models import Section
from service.clearance.models import AuditRecord, Run
from service.clearance.rules import describe_sweep, next_state, sweep_clears_original

SYSTEM = Principal(role="system", name="depot")  # author of the audit records it writes itself


def record_sweep(session: Session, sweep: Run, section: Section) -> None:
    """Link the swept run to its sweep run while (and only while) the sweep is complete.

    The audit gets one record per sweep that cleared a run, with both runs and the sweep's
    evidence; it is written once (a re-decision or a replay finds it and adds none).
    """
    original = session.get(Run, sweep.sweep_of) if sweep.sweep_of is not None else None
    if original is None:
        return
    if not sweep_clears_original(sweep.verdict):  # type: ignore[arg-type]
        if original.cleared_by == sweep.id:
            original.cleared_by = None  # late evidence took the proof away
        return
    original.cleared_by = sweep.id
    written = session.scalar(
        select(AuditRecord.id).where(
            AuditRecord.run_id == original.id, AuditRecord.action == "cleared_by_sweep"
        )
    )
    if written is None:
        session.add(
            AuditRecord(
                run_id=original.id,
                section=section.id,
                action="cleared_by_sweep",
                reason=describe_sweep(sweep.id, original.id, "complete"),
                actor=SYSTEM.name,
                actor_role=SYSTEM.role,
                recorded_at=utcnow(),  # when written, like every audit record
                state_before="awaiting_sweep",
                state_after=next_state("occupied", "complete", section.mode),
                evidence={
                    "swept_run_id": original.id,
                    "sweep_run_id": sweep.id,
                    "sweep_train": sweep.train,
                    "sweep_verdict": sweep.verdict,
                    "sweep_reasons": sweep.reasons,
                    "sweep_evidence": sweep.evidence,
                },
            )
        )
