"""Rebuild every derived table from the raw events (and re-apply the dispatchers' audit actions)."""

from __future__ import annotations

import heapq
from collections.abc import Iterator
from typing import Any

from sqlalchemy import delete, select, update
from sqlalchemy.orm import Session

from core.auth import Principal
from core.models import Device, Section
from ingest.handlers import Derivation, derivation_failed, derive
from ingest.liveness import heard_up_to
from ingest.models import RawEvent, Snapshot
from ingest.schemas import EVENT_ADAPTER, TailSnapshot
from ingest.store import derive_error_text
from service.clearance import actions
from service.clearance.models import (
    AuditRecord,
    AxleReading,
    CarPassage,
    EotReport,
    Run,
    WheelMarking,
)
from service.fleet.models import Measurement
from service.trains.models import TrainPosition

DERIVED = (Run, CarPassage, AxleReading, EotReport, WheelMarking, Snapshot, TrainPosition)


def _parse(raw: RawEvent) -> Any:
    if raw.kind == "tail_snapshot":
        return TailSnapshot.model_validate(raw.body)
    return EVENT_ADAPTER.validate_python(raw.body)


def _timeline(session: Session) -> Iterator[tuple[Any, ...]]:
    """Raw events and audit actions merged in the order the service received them."""
    raws = session.execute(select(RawEvent.received_at, RawEvent.id).order_by(RawEvent.id)).all()
    audits = session.execute(
        select(AuditRecord.recorded_at, AuditRecord.id).order_by(AuditRecord.id)
    ).all()
    merged = heapq.merge(
        ((at, 0, ident) for at, ident in raws), ((at, 1, ident) for at, ident in audits)
    )
    yield from merged


def reset_derived(session: Session) -> None:
    for model in DERIVED:
        session.execute(delete(model))
    session.execute(delete(Measurement).where(Measurement.raw_event_id.is_not(None)))
    session.execute(update(Section).values(state="free", current_run_id=None, state_since=None))
    session.execute(update(Device).values(last_seen_at=None))
    session.flush()


def _derive(session: Session, raw: RawEvent) -> bool:
    """Derive one raw event again; False when that fails. A failure puts the section it names
    to a person again, as it did when the event came (``derivation_failed``: the same fault
    run, whose audited decision the timeline then re-applies). The raw row is not touched."""
    device = session.get_one(Device, raw.device_id)
    try:
        event = _parse(raw)
    except Exception:
        return False
    derivation = Derivation(session, raw, event, device, replaying=True)
    try:
        with session.begin_nested():
            derive(derivation)
    except Exception as exc:
        derivation_failed(derivation, derive_error_text(exc))
        return False
    return True


def replay(session: Session, *, progress: Any = None) -> dict[str, int]:
    """Rebuild derived state; raw events and audit records themselves are never touched."""
    reset_derived(session)
    counts = {"events": 0, "failed": 0, "actions": 0, "refused_actions": 0}
    last_raw = 0  # no event replayed yet: none heard
    for _, source, ident in _timeline(session):
        if source == 0:
            if not _derive(session, session.get_one(RawEvent, ident)):
                counts["failed"] += 1
            counts["events"] += 1
            last_raw = ident
        else:
            record = session.get_one(AuditRecord, ident)
            if record.actor_role == "system":
                continue  # written by the derivation itself (a sweep's clearance), not an action
            who = Principal(role=record.actor_role, name=record.actor)
            try:
                # The action came when the events replayed so far were stored: liveness is
                # read from those, as it was live.
                with session.begin_nested(), heard_up_to(session, last_raw):
                    actions.act(
                        session,
                        record.run_id,
                        record.action,
                        record.reason,
                        who,
                        record.recorded_at,
                        audit=False,
                    )
                counts["actions"] += 1
            except Exception:
                counts["refused_actions"] += 1
        if progress is not None:
            progress(counts["events"] + counts["actions"] + counts["refused_actions"])
    session.flush()
    return counts
