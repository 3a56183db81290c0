"""Why a dispatcher's action is refused (409): named, with who decided before and when."""

from __future__ import annotations

from datetime import datetime

from sqlalchemy import select
from sqlalchemy.orm import Session

from core.errors import Conflict
from core.models import Section
from core.schemas import format_instant
from service.clearance import occupancy
from service.clearance.models import AuditRecord, Run
from service.clearance.overdue import overdue, waiting_words
from service.clearance.rules import SWEEP_FROM

ACTION_STATES = {"clear": "free", "keep_blocked": "blocked", "sweep": "awaiting_sweep"}
ACTION_WORDS = {"clear": "cleared", "keep_blocked": "kept blocked", "sweep": "sent to a sweep"}


def check_action(
    session: Session, run: Run, section: Section, action: str, at: datetime
) -> str | None:
    """Refuse (409) an action that cannot apply to the run now, naming why.

    Returns, for a run that has not arrived and whose section has been silent long enough
    (``overdue``), why a person may act on it anyway (kept in the audit), else None.
    """
    if run.status == "conflict":
        raise Conflict(
            f"run {run.id} (train {run.train}) departed into section {section.id} before it"
            f" was cleared and waits behind run {section.current_run_id}: decide run"
            f" {section.current_run_id} first"
        )
    if section.current_run_id != run.id:
        first = f": decide run {section.current_run_id} first" if occupancy.is_fault(run) else ""
        raise Conflict(f"run {run.id} is not the current run of section {section.id}{first}")
    missing = None
    if (
        run.arrived_at is None
        and not occupancy.is_fault(run)
        and not occupancy.overtaken(session, run)
    ):
        missing = overdue(session, run, at)
        if missing is None:
            raise Conflict(
                f"run {run.id} has not arrived yet; the train is still in section {section.id}"
                f" ({waiting_words()})"
            )
        if action == "clear" and section.state == "occupied":
            raise Conflict(
                f"run {run.id} has not arrived ({missing}): keep it blocked first, with a"
                " reason; a clear is a second, separate decision"
            )
    if section.state == ACTION_STATES[action]:
        raise Conflict(
            f"run {run.id} is already {ACTION_WORDS[action]}{_decided_by(session, run, action)}:"
            f" section {section.id} is {section.state}; nothing was recorded"
        )
    silent_train = missing is not None and section.state == "occupied"
    if action == "sweep" and section.state not in SWEEP_FROM and not silent_train:
        raise Conflict(
            f"section {section.id} is {section.state}: a sweep is asked for a section in alarm,"
            " review or blocked"
        )
    return missing


def _decided_by(session: Session, run: Run, action: str) -> str:
    """ " by olena (dispatcher) at 2026-11-23T10:41:00Z": who took the action, and when."""
    record = session.scalar(
        select(AuditRecord)
        .where(AuditRecord.run_id == run.id, AuditRecord.action == action)
        .order_by(AuditRecord.id.desc())
        .limit(1)
    )
    if record is None:
        return ""
    return f" by {record.actor} ({record.actor_role}) at {format_instant(record.recorded_at)}"
