"""Runs: departure opens one, arrival closes and decides it; evidence re-evaluates; people act."""

from __future__ import annotations

from datetime import datetime
from typing import Any

from sqlalchemy import event, select, update
from sqlalchemy.orm import Session

from core.auth import Principal
from core.database import utcnow
from core.errors import Conflict, NotFound
from core.models import Section
from core.schemas import format_instant
from ingest.models import Snapshot
from service.clearance.evidence import EVIDENCE_WINDOW, gather, run_at, side_of
from service.clearance.models import AuditRecord, AxleReading, CarPassage, Run
from service.clearance.rules import (
    SWEEP_FROM,
    decide,
    departure_opens_sweep,
    describe_sweep,
    next_state,
    sweep_clears_original,
)

BUSY_STATES = ("occupied", "awaiting_confirmation", "review", "alarm", "blocked", "awaiting_sweep")
ACTION_STATES = {"clear": "free", "keep_blocked": "blocked", "sweep": "awaiting_sweep"}
SYSTEM = Principal(role="system", name="depot")  # author of the audit records it writes itself


LOCKED = "depot_locked_sections"


def lock_section(session: Session, section_id: str) -> Section:
    """The section row, locked for the transaction: one writer decides a section at a time.

    Locked once per transaction: a group commit deriving many events of one section asks the
    database once; the row in the session is current, as nobody else may change it meanwhile.
    """
    locked: set[str] = session.info.setdefault(LOCKED, set())
    if section_id in locked:
        held = session.get(Section, section_id)
        if held is not None:
            return held
    section = session.scalar(select(Section).where(Section.id == section_id).with_for_update())
    if section is None:
        raise NotFound(f"section {section_id!r} does not exist")
    locked.add(section_id)
    return section


@event.listens_for(Session, "after_soft_rollback")
@event.listens_for(Session, "after_commit")
def _locks_released(session: Session, *_: object) -> None:
    # A commit ends the transaction; a rollback, even to a savepoint, may release the lock.
    session.info.pop(LOCKED, None)


def _set_state(section: Section, state: str, at: datetime) -> None:
    if section.state != state:
        section.state = state
        section.state_since = at


def open_run(
    session: Session,
    run_id: int,
    section_id: str,
    station: str,
    train: str,
    at: datetime,
    *,
    eot_unit: int | None = None,
    received: datetime | None = None,
) -> dict[str, Any]:
    """``train_departed``: the train takes the block, or a conflict is recorded and raised.

    Into a section awaiting a sweep the train is the sweep run: no conflict, it holds the
    section and remembers the run it sweeps. ``received`` is when the server received the
    departure: the departure-side devices' liveness is judged then.
    """
    section = lock_section(session, section_id)
    run = Run(
        id=run_id,
        section=section.id,
        train=train,
        # Single track, both directions: the departing station decides the direction.
        from_station=station,
        to_station=section.to_station if station == section.from_station else section.from_station,
        departed_at=at,
        status="running",
        reasons=[],
        evidence={},
        eot_unit=eot_unit,
        sweep=False,
        departure_received_at=received,
    )
    if departure_opens_sweep(section.state):
        run.sweep, run.sweep_of = True, section.current_run_id
    elif section.state in BUSY_STATES:
        holder = session.get(Run, section.current_run_id) if section.current_run_id else None
        run.status = "conflict"
        run.verdict = None
        detail = f"train {train} departed into section {section.id}, which is {section.state}" + (
            f" (run {holder.id}, train {holder.train})" if holder else ""
        )
        run.reasons = [detail]
        session.add(run)
        _set_state(section, "alarm", at)
        session.flush()
        return {"run": run_id, "conflict": True, "detail": detail, "section_state": section.state}
    session.add(run)
    section.current_run_id = run_id
    _set_state(section, "occupied", at)
    adopted = adopt_departure_evidence(session, run)
    session.flush()
    out: dict[str, Any] = {"run": run_id, "section_state": section.state}
    if run.sweep:
        out.update(sweep=True, sweep_of=run.sweep_of)
    return {**out, "adopted_evidence": adopted}


def adopt_departure_evidence(session: Session, run: Run) -> int:
    """Departure-side readers and cameras see the train just before the interlocking reports
    the departure: their evidence, stored without a run, now joins this run."""
    adopted = 0
    models: tuple[type[Snapshot] | type[CarPassage] | type[AxleReading], ...] = (
        Snapshot,
        CarPassage,
        AxleReading,
    )
    for model in models:
        result = session.execute(
            update(model)
            .where(
                model.run_id.is_(None),
                model.section == run.section,
                model.station == run.from_station,
                model.occurred_at >= run.departed_at - EVIDENCE_WINDOW,
                model.occurred_at <= run.departed_at,
            )
            .values(run_id=run.id, side="departure")
        )
        adopted += result.rowcount  # type: ignore[attr-defined]
    return adopted


def close_run(
    session: Session,
    section_id: str,
    station: str,
    train: str,
    at: datetime,
    *,
    received: datetime | None = None,
) -> dict[str, Any]:
    """``train_arrived``: the current run arrives at the far station and is decided; the
    arrival-side devices' liveness is judged at ``received``, when the server got the arrival."""
    section = lock_section(session, section_id)
    run = session.get(Run, section.current_run_id) if section.current_run_id else None
    if run is None or run.status != "running":
        return {"run": None, "warning": f"no train was running in section {section.id}"}
    if station != run.to_station:
        return {
            "run": run.id,
            "warning": f"arrival reported at {station}, but run {run.id} goes to {run.to_station}",
        }
    run.arrived_at, run.arrival_received_at, run.arrival_train = at, received, train
    run.status = "arrived"
    return evaluate(session, run, section)


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


def evaluate(
    session: Session, run: Run, section: Section, *, notes: list[str] | None = None
) -> dict[str, Any]:
    """Decide an arrived run from its evidence; the section follows when the run holds it."""
    previous = run.verdict
    notes = [*time_contradictions(run), *train_contradictions(run), *(notes or [])]
    gathered = gather(session, run, section)
    decision = decide(gathered.evidence)
    verdict, reasons = decision.verdict, [*decision.reasons, *(notes or [])]
    if notes and verdict == "complete":
        verdict = "undetermined"  # a mismatched train number or clock needs a person's eyes
    if run.sweep and run.sweep_of is not None:
        reasons.append(describe_sweep(run.id, run.sweep_of, verdict))
    run.verdict, run.reasons, run.evidence = verdict, reasons, gathered.summary
    if run.decided_at is None:
        run.decided_at = run.arrived_at
    at = run.arrived_at or run.departed_at
    if run.sweep and run.sweep_of is not None:
        _record_sweep(session, run, section)
    if section.current_run_id == run.id:
        _set_state(section, next_state(section.state, verdict, section.mode), at)
        if section.state == "free":
            promote_conflict(session, section, at)
    elif verdict == "incomplete" and previous != "incomplete":
        # Late proof that an earlier train lost cars: they may still stand in the section the
        # next train now holds (clearance.md: late evidence of incompleteness raises the alarm).
        _set_state(section, next_state(section.state, verdict, section.mode), utcnow())
    session.flush()
    return {"run": run.id, "verdict": verdict, "reasons": reasons, "section_state": section.state}


def _record_sweep(session: Session, sweep: Run, section: Section) -> None:
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


def promote_conflict(session: Session, section: Section, at: datetime) -> None:
    """When a section frees, a train recorded as a conflict (still in it) now holds it."""
    waiting = session.scalar(
        select(Run)
        .where(Run.section == section.id, Run.status == "conflict")
        .order_by(Run.departed_at)
    )
    if waiting is not None:
        waiting.status = "running"
        section.current_run_id = waiting.id
        _set_state(section, "occupied", at)


def attach(
    session: Session, row: Any, section_id: str, station: str, at: datetime
) -> dict[str, Any]:
    """Attach a piece of evidence to the run holding the section then; re-decide if arrived."""
    section = lock_section(session, section_id)
    run = run_at(session, section_id, at, station)
    # Departure-side devices see a train before it leaves; after the run has arrived they
    # are seeing the next train (a sweep train, say), which adopts their evidence on departure.
    if run is not None and run.arrived_at is not None and at > run.arrived_at:
        run = None if station == run.from_station else run
    if run is None:
        row.run_id, row.side = None, None
        session.flush()
        return {"run": None, "note": f"no run in section {section_id} at that time; evidence kept"}
    row.run_id, row.side = run.id, side_of(run, station)
    session.flush()
    if run.status == "arrived":
        return {"run": run.id, "side": row.side, "reevaluated": evaluate(session, run, section)}
    return {"run": run.id, "side": row.side}


ACTION_WORDS = {"clear": "cleared", "keep_blocked": "kept blocked", "sweep": "sent to a sweep"}


def check_action(run: Run, section: Section, action: str) -> None:
    """Refuse (409) an action that cannot apply to the run now, naming why."""
    if section.current_run_id != run.id:
        raise Conflict(f"run {run.id} is not the current run of section {section.id}")
    if run.status != "arrived":
        raise Conflict(
            f"run {run.id} has not arrived yet; the train is still in section {section.id}"
        )
    if section.state == ACTION_STATES[action]:
        raise Conflict(
            f"run {run.id} is already {ACTION_WORDS[action]}: section {section.id} is"
            f" {section.state}; nothing was recorded"
        )
    if action == "sweep" and section.state not in SWEEP_FROM:
        raise Conflict(
            f"section {section.id} is {section.state}: a sweep is asked for a section in alarm,"
            " review or blocked"
        )


def act(
    session: Session,
    run_id: int,
    action: str,
    reason: str,
    actor: Principal,
    at: datetime,
    *,
    audit: bool = True,
) -> AuditRecord | None:
    """A dispatcher's ``clear``, ``keep_blocked`` or ``sweep`` on the section's current, arrived
    run. ``sweep`` only where nothing proves the section empty (alarm, review, blocked); a
    ``clear`` of a section awaiting its sweep is audited as a force-clear.

    The one way to act on a run: the API and the review form both call it. An action that
    asks for the state the section is already in (a second ``clear``, a double click) is
    refused (409) before anything is written, so the audit holds each decision once.
    """
    run = session.get(Run, run_id)
    if run is None:
        raise NotFound(f"run {run_id} does not exist")
    section = lock_section(session, run.section)
    check_action(run, section, action)
    before = section.state
    gathered = gather(session, run, section)
    _set_state(section, ACTION_STATES[action], at)
    run.auto = False
    if action == "clear":
        promote_conflict(session, section, at)
    record = None
    if audit:
        record = AuditRecord(
            run_id=run.id,
            section=section.id,
            action=action,
            reason=reason,
            actor=actor.name,
            actor_role=actor.role,
            recorded_at=at,
            state_before=before,
            state_after=section.state,
            evidence={
                "verdict": run.verdict,
                "reasons": run.reasons,
                **gathered.summary,
                **(
                    {"force_clear": True}
                    if action == "clear" and before == "awaiting_sweep"
                    else {}
                ),
            },
        )
        session.add(record)
    session.flush()
    return record
