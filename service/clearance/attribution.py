"""Which run a piece of evidence belongs to: by section, the device's station and time.

On a single-track section the block lets one train in at a time, but a train may depart into a
section that was not cleared (a conflict), and events reach depot in any order. The rules, in
the order they are tried (the first that finds a run decides):

1. A departure-side device (at the run's ``from_station``) sees a train around its departure:
   from :attr:`AttachmentWindows.before_departure` before to
   :attr:`AttachmentWindows.after_departure` after it, never after its arrival. Of several
   such departures the nearest in time owns it — except that evidence dated *before* a
   departure is never taken from a train that holds the section at the station then (the
   earlier train's arrival).
2. An arrival-side device sees the trains holding the section (departed, not yet arrived) in
   the order they departed: single track, no overtaking — first in, first out.
3. Within :attr:`AttachmentWindows.after_arrival` after an arrival, an arrival-side device
   still sees that train (device clocks differ by seconds); later than that it sees the next
   train, or none — never the train that arrived.

Evidence that fits no run is kept without one; a departure reported later takes what fits it
(:func:`reclaim`), also from an earlier run, which is then decided again.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from datetime import datetime, timedelta
from typing import Any

from sqlalchemy import Select, and_, or_, select
from sqlalchemy.orm import Session

from ingest.models import Snapshot
from service.clearance.models import AxleReading, CarPassage, EotReport, Run


@dataclass(frozen=True)
class AttachmentWindows:
    """How far from a run's departure and arrival its devices' evidence still belongs to it.

    Attributes
    ----------
    before_departure, after_departure
        Readers, counters and cameras at the departure station see the train while it leaves:
        this long before and after the interlocking reports the departure.
    after_arrival
        An arrival-side report dated after the arrival belongs to that train only this long
        after it (device clocks differ by seconds; the tail passes the camera before the
        interlocking reports the arrival). Longer, and it could be the next train's: a later
        train's photo must never decide an earlier run.
    """

    before_departure: timedelta = timedelta(minutes=10)
    after_departure: timedelta = timedelta(minutes=10)
    after_arrival: timedelta = timedelta(seconds=60)


WINDOWS = AttachmentWindows()
EVIDENCE_WINDOW = WINDOWS.before_departure
# Runs looked at for one piece of evidence: the latest departures of the section (a conflict
# puts two or three trains in it at most).
CANDIDATES = 8
EVIDENCE_MODELS: tuple[Any, ...] = (Snapshot, CarPassage, AxleReading, EotReport)


# A run that has not arrived holds the section while it is running or waiting (conflict); one a
# dispatcher released without an arrival (``overtaken``) holds nothing any more.
IN_SECTION = ("running", "conflict")


def _holds(run: Run, at: datetime) -> bool:
    if run.departed_at > at:
        return False
    return at <= run.arrived_at if run.arrived_at is not None else run.status in IN_SECTION


def owner(candidates: Sequence[Run], at: datetime, station: str) -> Run | None:
    """The run that evidence from ``station`` dated ``at`` belongs to (the module's rules),
    among ``candidates`` (the section's runs); a pure function, so replay finds the same."""
    holding = [r for r in candidates if r.to_station == station and _holds(r, at)]
    departing = [
        r
        for r in candidates
        if r.from_station == station
        and -WINDOWS.before_departure <= at - r.departed_at <= WINDOWS.after_departure
        and (at <= r.arrived_at if r.arrived_at is not None else r.status in IN_SECTION)
        and (r.departed_at <= at or not holding)
    ]
    if departing:
        return min(departing, key=lambda r: (abs(at - r.departed_at), -r.id))
    if holding:
        return min(holding, key=lambda r: (r.departed_at, r.id))
    after = [
        r
        for r in candidates
        if r.to_station == station
        and r.arrived_at is not None
        and r.arrived_at < at <= r.arrived_at + WINDOWS.after_arrival
    ]
    return max(after, key=lambda r: (r.arrived_at, r.id)) if after else None


def _owners(section: str, start: datetime, end: datetime) -> Select[Any]:
    """The query of the runs of ``section`` that could own evidence dated from ``start`` to
    ``end``, latest departure first (one filter for :func:`candidates` and :func:`_spanning`)."""
    return (
        select(Run)
        .where(Run.section == section, Run.departed_at <= end + WINDOWS.before_departure)
        .where(
            or_(
                Run.arrived_at >= start - WINDOWS.after_arrival,
                and_(Run.arrived_at.is_(None), Run.status.in_(IN_SECTION)),
            )
        )
        .order_by(Run.departed_at.desc(), Run.id.desc())
    )


def candidates(session: Session, section: str, start: datetime, end: datetime) -> list[Run]:
    """The section's latest runs that could own evidence dated from ``start`` to ``end``."""
    return list(session.scalars(_owners(section, start, end).limit(CANDIDATES)))


def _eligible(run: Run, at: datetime) -> bool:
    """The filter of :func:`candidates` for one instant, in Python."""
    if run.departed_at > at + WINDOWS.before_departure:
        return False
    if run.arrived_at is None:
        return run.status in IN_SECTION
    return run.arrived_at >= at - WINDOWS.after_arrival


# The section's runs read once per transaction (a group commit, a broker batch, replay), kept
# with the span of evidence times they answer for; valid while the section lock is held (no
# other writer changes its runs) and until the transaction opens, arrives or releases a run
# (``forget_runs``); dropped at commit and rollback with the locks.
LOCKED = "depot_locked_sections"
SECTION_RUNS = "depot_section_runs"
# The span of evidence times one read of the section's runs answers for (a group's readings
# are minutes apart); any span gives exactly the runs the query would, only more or fewer.
SPAN_READ = timedelta(minutes=30)


def forget_runs(session: Session, section: str) -> None:
    """The section's runs changed (a departure, an arrival, a dispatcher's action)."""
    session.info.get(SECTION_RUNS, {}).pop(section, None)


def run_at(session: Session, section: str, at: datetime, station: str) -> Run | None:
    """The run holding ``section`` at time ``at``, for evidence from a device at ``station``.

    Under the section's lock the section's runs are read once for a whole group of evidence
    (exactly the candidates the query would give: same filter, order and limit)."""
    if section not in session.info.get(LOCKED, ()):
        return owner(candidates(session, section, at, at), at, station)
    cache: dict[str, tuple[datetime, datetime, list[Run]]] = session.info.setdefault(
        SECTION_RUNS, {}
    )
    held = cache.get(section)
    if held is None or not held[0] <= at <= held[1]:
        start, end = at - SPAN_READ, at + SPAN_READ
        if held is not None:
            start, end = min(held[0], start), max(held[1], end)
        held = (start, end, _spanning(session, section, start, end))
        cache[section] = held
    chosen = [r for r in held[2] if _eligible(r, at)][:CANDIDATES]
    return owner(chosen, at, station)


def _spanning(session: Session, section: str, start: datetime, end: datetime) -> list[Run]:
    """Every run of the section that :func:`candidates` could give for an instant from
    ``start`` to ``end`` (no limit), latest departure first."""
    return list(session.scalars(_owners(section, start, end)))


def reclaim(session: Session, run: Run) -> tuple[int, set[int]]:
    """A departure just recorded takes the evidence that belongs to it: stored without a run
    (it came first), or attached to an earlier run before this departure was known.

    Returns how many pieces it took, and the ids of the earlier runs that lost evidence (to
    be decided again).
    """
    since = run.departed_at - WINDOWS.before_departure
    rows = [
        row
        for model in EVIDENCE_MODELS
        for row in session.scalars(
            select(model).where(model.section == run.section, model.occurred_at >= since)
        )
    ]
    if not rows:
        return 0, set()
    latest = max(row.occurred_at for row in rows)
    runs = candidates(session, run.section, since, latest)
    losers: set[int] = set()
    taken = 0
    for row in rows:
        if row.run_id == run.id or owner(runs, row.occurred_at, row.station) is not run:
            continue
        if row.run_id is not None:
            losers.add(row.run_id)
        row.run_id, row.side = run.id, side_of(run, row.station)
        taken += 1
    return taken, losers


def side_of(run: Run, station: str) -> str | None:
    if station == run.from_station:
        return "departure"
    if station == run.to_station:
        return "arrival"
    return None
