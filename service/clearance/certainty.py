"""Evidence that cannot be placed in one run with certainty: a doubt, never proof.

A device's clock may be ahead (up to the protocol's allowed skew) or behind (without bound).
Evidence is attached by its device time (``attribution``); here a run's decision learns which
of the evidence near it is *uncertain*, and each such piece becomes a reason for a person to
look — for every run it may belong to — instead of proof for the one it happens to be
attached to, or nothing at all:

- attached to the run, but another run is a rival for it (:func:`attribution.place`), or the
  rules, with the runs now known, no longer give it to this run;
- attached to another run or to none, with this run among its rivals;
- attached to no run, or uncertain, and *received by the server* while this run held the
  section (from :attr:`AttachmentWindows.before_departure` before its departure was received
  to :attr:`AttachmentWindows.recently_closed` after its arrival was), and not dated after
  the run's arrival by more than a clock may be ahead: the server's clock says it may be this
  train's whatever the device's clock says (a counter 15 min behind).

Everything is derived from the stored evidence and runs, so a re-decision and a replay give
the same. Spec gap (clearance.md, protocol.md say evidence belongs to "the run occupying the
section at occurred_at" and do not say what a wrong clock does): the safe reading is chosen.
Evidence certainly another run's (its device time squarely in that run) is taken at its word,
even when received during this run: a clock behind by more than the gap between two trains is
not caught here.
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime, timedelta
from typing import Any

from sqlalchemy import and_, or_, select
from sqlalchemy.orm import Session

from core.schemas import format_instant
from ingest.models import RawEvent, Snapshot
from service.clearance.attribution import (
    EVIDENCE_MODELS,
    LOCKED,
    REACH_AFTER_ARRIVAL,
    SECTION_RUNS,
    WINDOWS,
    Placement,
    eligible_at,
    place,
    spanning,
)
from service.clearance.models import AxleReading, CarPassage, EotReport, Run


@dataclass(frozen=True)
class Judgement:
    """For one run: the attached evidence that proves nothing (row ids) and why, in words."""

    unproven: frozenset[int]
    doubts: tuple[str, ...]


def _received_window(run: Run) -> tuple[datetime, datetime | None]:
    """When the server may receive this train's evidence (device times stand in for runs
    stored before receive times were recorded); ``None``: the run has not arrived."""
    start = (run.departure_received_at or run.departed_at) - WINDOWS.before_departure
    arrival = run.arrival_received_at or run.arrived_at
    return start, None if arrival is None else arrival + WINDOWS.recently_closed


def received_during(run: Run, row: Any, received: datetime | None) -> bool:
    """Received while ``run`` held the section (or soon after), and not dated after the run's
    arrival by more than a clock may be ahead: evidence dated later cannot be this train's
    with an allowed clock (and an arrival interlocking behind leaves the run without its
    arrival evidence, which asks for a person anyway)."""
    if received is None:
        return False
    if run.arrived_at is not None and row.occurred_at > run.arrived_at + REACH_AFTER_ARRIVAL:
        return False
    start, end = _received_window(run)
    return start <= received and (end is None or received <= end)


def _what(row: Any) -> str:
    if isinstance(row, Snapshot):
        return f"a tail image (snapshot {row.id}, {row.verdict or 'not judged'})"
    if isinstance(row, AxleReading):
        return f"an axle count of {row.axles}"
    if isinstance(row, CarPassage):
        return f"a car reading ({row.car_id or row.number or 'unread'})"
    if isinstance(row, EotReport):
        return f"an EOT report (unit {row.unit_address}, {row.pressure_psig} psig)"
    return "evidence"


def words(row: Any) -> str:
    """The doubt, in a dispatcher's words (the same for every run it concerns)."""
    return (
        f"{_what(row)} from {row.device_id} dated {format_instant(row.occurred_at)} cannot be"
        " placed in one run with certainty (a device clock may be wrong): it proves nothing;"
        " a person must look"
    )


def _rows(session: Session, run: Run) -> list[Any]:
    """The section's evidence that may concern ``run``: attached to it, dated near it, or
    attached to no run and received while it held the section."""
    start = run.departed_at - WINDOWS.before_departure
    ends = [run.departed_at + WINDOWS.after_departure + WINDOWS.clock_ahead]
    if run.arrived_at is not None:
        ends.append(run.arrived_at + REACH_AFTER_ARRIVAL)
    end = max(ends) if run.arrived_at is not None else None
    lo, hi = _received_window(run)
    received = select(RawEvent.id).where(
        RawEvent.section == run.section, RawEvent.received_at >= lo
    )
    if hi is not None:
        received = received.where(RawEvent.received_at <= hi)
    rows: list[Any] = []
    for model in EVIDENCE_MODELS:
        dated = model.occurred_at >= start
        if end is not None:
            dated = and_(dated, model.occurred_at <= end)
        query = select(model).where(
            model.section == run.section,
            or_(
                model.run_id == run.id,
                dated,
                and_(model.run_id.is_(None), model.id.in_(received)),
            ),
        )
        rows.extend(session.scalars(query))
    return rows


def _settled(placement: Placement, row: Any) -> bool:
    """Certainly its owner's, and attached to it: proof for that run only."""
    return placement.certain and placement.owner is not None and row.run_id == placement.owner.id


def judge(session: Session, run: Run) -> Judgement:
    """What of the evidence near ``run`` is uncertain for it (the module's rules)."""
    rows = _rows(session, run)
    if not rows:
        return Judgement(frozenset(), ())
    times = {row.id: row.occurred_at for row in rows}
    received: dict[int, datetime] = {
        ident: at
        for ident, at in session.execute(
            select(RawEvent.id, RawEvent.received_at).where(RawEvent.id.in_(list(times)))
        )
    }
    runs = spanning(session, run.section, min(times.values()), max(times.values()))
    unproven: set[int] = set()
    doubts: list[str] = []
    for row in sorted(rows, key=lambda r: (r.occurred_at, r.id)):
        placement = place(eligible_at(runs, row.occurred_at), row.occurred_at, row.station)
        if _settled(placement, row):
            continue
        involved = {r.id for r in placement.rivals} | {row.run_id}
        if run.id in involved or received_during(run, row, received.get(row.id)):
            doubts.append(words(row))
            if row.run_id == run.id:
                unproven.add(row.id)
    return Judgement(frozenset(unproven), tuple(doubts))


# Under the section's lock, the runs a receive time may doubt are read once for a span of
# receive times (a group's events are received within milliseconds of each other).
RECEIVED_RUNS = "depot_runs_by_received"
RECEIVED_SPAN = timedelta(minutes=5)


def _runs_received_near(
    session: Session, section: str, earliest: datetime, latest: datetime
) -> list[Run]:
    """Every run of ``section`` that may have held it when evidence was received at some
    instant from ``earliest`` to ``latest`` (a superset: :func:`received_during` decides)."""
    return list(
        session.scalars(
            select(Run).where(
                Run.section == section,
                or_(
                    Run.departure_received_at <= latest + WINDOWS.before_departure,
                    Run.departure_received_at.is_(None),
                ),
                or_(
                    Run.arrival_received_at >= earliest - WINDOWS.recently_closed,
                    Run.arrival_received_at.is_(None),
                ),
            )
        )
    )


def _received_near(session: Session, section: str, received: datetime) -> list[Run]:
    """:func:`_runs_received_near` for one instant, read once per span under the lock.

    The read is kept only while the section's runs, as :func:`attribution.placement_at` holds
    them, are the same object: a departure, an arrival or an action drops that
    (``forget_runs``), and with it this read, so nothing a group changed is missed."""
    runs_held = session.info.get(SECTION_RUNS, {}).get(section)
    if section not in session.info.get(LOCKED, ()) or runs_held is None:
        return _runs_received_near(session, section, received, received)
    cache: dict[str, tuple[Any, datetime, datetime, list[Run]]] = session.info.setdefault(
        RECEIVED_RUNS, {}
    )
    held = cache.get(section)
    if held is None or held[0] is not runs_held or not held[1] <= received <= held[2]:
        earliest, latest = received - RECEIVED_SPAN, received + RECEIVED_SPAN
        runs = _runs_received_near(session, section, earliest, latest)
        held = cache[section] = (runs_held, earliest, latest, runs)
    return held[3]


def doubted_runs(
    session: Session, section: str, row: Any, received: datetime | None, placement: Placement
) -> list[Run]:
    """The arrived runs, other than the one ``row`` was attached to, that the new evidence
    casts doubt on (to be decided again now): none when it is certain. ``placement`` is the
    row's own (:func:`attribution.placement_at`), as ``attach`` found it."""
    if _settled(placement, row):
        return []
    found = {r.id: r for r in placement.rivals}
    if received is not None:
        nearby = _received_near(session, section, received)
        found.update({r.id: r for r in nearby if received_during(r, row, received)})
    return sorted(
        (r for r in found.values() if r.id != row.run_id and r.arrived_at is not None),
        key=lambda r: (r.departed_at, r.id),
    )
