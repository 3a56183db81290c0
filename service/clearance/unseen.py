"""A train arriving out of a section nobody saw it enter (no ``train_departed`` reached depot).

Safety stance: a section whose state is unknown is never shown as clear. An arrival that finds
no open run is a doubt: which train was in the section, since when, and whether another is
still in it, nobody knows. The arrival becomes an *unseen-entry run* — the run of that
arrival, with the arrival's raw id as its id (a departure's raw id is a normal run's id, so the
two never collide) and the arrival's time standing in for the departure nobody saw. It is
decided like any run, never ``complete`` (``Run.conflict`` holds the words), and the section
goes to ``review`` (or waits behind the section's current run, like a conflict): it is on the
review screen, and a dispatcher decides it like any run (``POST /runs/{id}/decision``).

The departure that explains it (same train, same direction, dated before the arrival) may
still reach depot: it takes the arrival back (``service.open_run``). If no person acted on the
unseen-entry run yet, that run is removed (it was only the doubt the departure now answers);
if one did, it stays (``explained``) with its audit, and the departure takes the arrival.
"""

from __future__ import annotations

from datetime import datetime

from sqlalchemy import select, update
from sqlalchemy.orm import Session

from core.models import Section
from service.clearance.attribution import EVIDENCE_MODELS
from service.clearance.models import Run

# An unseen-entry run that a person acted on, whose departure then came: kept for its audit.
EXPLAINED = "explained"


def is_unseen(run: Run) -> bool:
    """The run of an arrival nobody saw enter (its id is its arrival's raw id)."""
    return run.arrival_id is not None and run.id == run.arrival_id


def words(train: str, station: str, section: str) -> str:
    return (
        f"train {train} arrived at {station} out of section {section}, but nobody saw it enter"
        " the section (no departure reached depot): which train was in it, and whether"
        " another still is, is unknown; a person must look"
    )


def open_unseen(
    section: Section,
    station: str,
    train: str,
    at: datetime,
    received: datetime | None,
    arrival_id: int,
) -> Run:
    """The unseen-entry run of an arrival that found no run (not yet in the session)."""
    other = section.from_station if station == section.to_station else section.to_station
    return Run(
        id=arrival_id,
        section=section.id,
        train=train,
        from_station=other,
        to_station=station,
        # unknown: the arrival's time stands in (the latest the train can have entered)
        departed_at=at,
        arrived_at=at,
        departure_received_at=received,
        arrival_received_at=received,
        arrival_train=train,
        arrival_id=arrival_id,
        status="arrived",
        reasons=[],
        evidence={},
        sweep=False,
        conflict=words(train, station, section.id),
    )


def explained_by(session: Session, run: Run) -> Run | None:
    """The unseen-entry run whose arrival this departure explains: the same train, arriving
    at the far end of ``run``, dated at or after the departure; the earliest such."""
    candidates = session.scalars(
        select(Run)
        .where(Run.section == run.section, Run.id != run.id, Run.train == run.train)
        .where(Run.to_station == run.to_station, Run.arrived_at >= run.departed_at)
        .where(Run.id == Run.arrival_id)
        .order_by(Run.arrived_at, Run.id)
    )
    return next(iter(candidates), None)


def release(session: Session, unseen: Run) -> bool:
    """Give the arrival back for its departure to take. Returns whether the run was removed
    (nobody acted on it) — else it stays, ``explained``, with its audit."""
    unseen.arrival_id = None
    if not unseen.auto:
        unseen.status = EXPLAINED
        return False
    for model in EVIDENCE_MODELS:  # its evidence is for the departure to take (reclaim)
        session.execute(
            update(model).where(model.run_id == unseen.id).values(run_id=None, side=None)
        )
    session.delete(unseen)
    return True
