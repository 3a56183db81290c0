"""JSON views of sections, runs and audit records (shared by the API and the review screen)."""

from __future__ import annotations

from datetime import datetime
from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session

from core.models import Section
from core.schemas import format_optional_instant
from service.clearance import unseen
from service.clearance.models import AuditRecord, Run
from service.clearance.occupancy import FAULT
from service.clearance.revision import revision

QUEUE_STATES = ("alarm", "review", "awaiting_confirmation", "blocked")


def _iso(value: datetime | None) -> str | None:
    # One way to write an instant (milliseconds at most): the screen shows these strings too.
    return format_optional_instant(value)


def audit_out(record: AuditRecord) -> dict[str, Any]:
    return {
        "id": record.id,
        "run_id": record.run_id,
        "section": record.section,
        "action": record.action,
        "reason": record.reason,
        "actor": record.actor,
        "actor_role": record.actor_role,
        "recorded_at": _iso(record.recorded_at),
        "state_before": record.state_before,
        "state_after": record.state_after,
        "evidence": record.evidence,
    }


def run_out(session: Session, run: Run) -> dict[str, Any]:
    overrides = session.scalars(
        select(AuditRecord).where(AuditRecord.run_id == run.id).order_by(AuditRecord.id)
    ).all()
    return {
        "id": run.id,
        "section": run.section,
        "train": run.train,
        "status": run.status,
        "conflict": run.conflict,
        # False for the run of an arrival nobody saw enter the section (``unseen``)
        "departure_seen": not unseen.is_unseen(run),
        "from_station": run.from_station,
        "to_station": run.to_station,
        "departed_at": _iso(run.departed_at),
        "arrived_at": _iso(run.arrived_at),
        "sweep": run.sweep,
        "sweep_of": run.sweep_of,
        "cleared_by": run.cleared_by,
        "eot_unit": run.eot_unit,
        "evidence": run.evidence,
        "decision": None
        if run.verdict is None and run.status != "conflict"
        else {
            "verdict": run.verdict or "undetermined",
            "reasons": run.reasons,
            "auto": run.auto,
            **acted(overrides[-1] if overrides else None),
        },
        "overrides": [audit_out(r) for r in overrides],
        "revision": revision(
            run, session.get(Section, run.section), overrides[-1].id if overrides else None
        ),
    }


def acted(record: AuditRecord | None) -> dict[str, Any]:
    """The latest action on the run (a person's, or depot's own for a sweep): what, who, when."""
    if record is None:
        return {"action": None, "actor": None, "acted_at": None}
    return {"action": record.action, "actor": record.actor, "acted_at": _iso(record.recorded_at)}


def section_out(session: Session, section: Section) -> dict[str, Any]:
    run = None
    if section.current_run_id is not None and section.state != "free":
        found = session.get(Run, section.current_run_id)
        run = run_out(session, found) if found else None
    conflicts = session.scalars(
        select(Run.id).where(Run.section == section.id, Run.status == "conflict")
    ).all()
    # Events that could not be processed, waiting for a person behind the current run.
    faults = session.scalars(
        select(Run.id)
        .where(Run.section == section.id, Run.status == FAULT, Run.auto.is_(True))
        .where(Run.id != (section.current_run_id or 0))
        .order_by(Run.departed_at, Run.id)
    ).all()
    return {
        "id": section.id,
        "state": section.state,
        "mode": section.mode,
        "from_station": section.from_station,
        "to_station": section.to_station,
        "state_since": _iso(section.state_since),
        "last_run_id": section.current_run_id,
        "conflict_runs": list(conflicts),
        "fault_runs": list(faults),
        "run": run,
    }
