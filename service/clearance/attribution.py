"""Which run a piece of evidence belongs to: by section, the device's station and time.

On a single-track section the block lets one train in at a time, but a train may depart into a
section that was not cleared (a conflict), and events reach depot in any order. The rules, in
the order they are tried (the first that finds a run decides):

1. A departure-side device (at the run's ``from_station``) sees a train around its departure:
   from :attr:`AttachmentWindows.adopt_before_departure` before to
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

Device clocks may be wrong (protocol.md accepts a clock up to ``DEPOT_MAX_CLOCK_SKEW_S`` ahead,
and cannot bound one behind). :func:`place` therefore also names every run that could own the
evidence were its device's clock ahead by up to :attr:`AttachmentWindows.clock_ahead`; evidence
is *certain* only when those rules leave no other run (or only trains that shared the section,
which ``occupancy`` already puts to a person). Evidence that is not certain is still attached
to one run at most (the rules above), but proves nothing for any run: ``certainty`` makes it a
doubt for each run it may belong to.
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
    adopt_before_departure, after_departure
        Readers, counters and cameras at the departure station see the train while it leaves:
        this long before and after the interlocking reports the departure, and such evidence
        is the run's. Before the departure the train does not hold the section yet (protocol.md:
        evidence belongs to the run occupying the section at ``occurred_at``), so only clock
        differences of seconds are allowed, as after an arrival; longer, and the reads could be
        the previous train's or a shunting move's (an independent trial: reads dated 3 min
        before a departure made a false alarm).
    before_departure
        Evidence dated up to this long before a departure may still be that train's (a device
        clock behind, a reader before the departure signal) but is not adopted: a doubt for the
        run, never proof (``certainty``). Also how long before a departure was received the
        server may receive the train's evidence.
    after_arrival
        An arrival-side report dated after the arrival belongs to that train only this long
        after it (device clocks differ by seconds; the tail passes the camera before the
        interlocking reports the arrival). Longer, and it could be the next train's: a later
        train's photo must never decide an earlier run.
    clock_ahead
        How far ahead a device clock may be: the protocol's ``DEPOT_MAX_CLOCK_SKEW_S`` default
        (an event dated further ahead of the server is refused). Evidence dated up to this much
        after a run's windows may still be that run's: it is not certain.
    recently_closed
        Evidence that fits no run by its device time, received by the server while a run held
        the section or up to this long after its arrival was received, may be that run's with
        its device's clock wrong (a clock behind has no bound): a person must look.
    """

    adopt_before_departure: timedelta = timedelta(seconds=60)
    before_departure: timedelta = timedelta(minutes=10)
    after_departure: timedelta = timedelta(minutes=10)
    after_arrival: timedelta = timedelta(seconds=60)
    clock_ahead: timedelta = timedelta(seconds=300)
    recently_closed: timedelta = timedelta(minutes=10)


WINDOWS = AttachmentWindows()
# How long after its arrival a run can still be a rival for evidence (:func:`place`).
# (A tail image is taken before the arrival is reported; a clock ahead dates it later, by at
# most ``clock_ahead``.)
REACH_AFTER_ARRIVAL = max(WINDOWS.after_arrival, WINDOWS.clock_ahead)
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


@dataclass(frozen=True)
class Placement:
    """Where evidence dated ``at`` from one station belongs.

    ``owner`` is the run the module's rules give it; ``rivals`` every run it could belong to
    were the device clock ahead by up to :attr:`AttachmentWindows.clock_ahead` (the owner among
    them); ``certain`` when no rival casts doubt: none but the owner, or only trains holding
    the section together (their runs are a person's matter anyway: ``occupancy.notes``)."""

    owner: Run | None
    rivals: tuple[Run, ...]
    certain: bool


def _in_run(run: Run, at: datetime, slack: timedelta) -> bool:
    """Not after the run's arrival (plus ``slack``); a run not arrived must still hold."""
    if run.arrived_at is not None:
        return at <= run.arrived_at + slack
    return run.status in IN_SECTION


def _departing(
    candidates: Sequence[Run], at: datetime, station: str, slack: timedelta, holding: bool
) -> list[Run]:
    """The departures from ``station`` that evidence dated ``at`` fits: adopted (no
    ``slack``), or possible with a device clock wrong (``slack``: ahead by that much, or behind
    by up to :attr:`AttachmentWindows.before_departure`)."""
    before = WINDOWS.before_departure if slack else WINDOWS.adopt_before_departure
    return [
        r
        for r in candidates
        if r.from_station == station
        and -before <= at - r.departed_at <= WINDOWS.after_departure + slack
        and _in_run(r, at, REACH_AFTER_ARRIVAL if slack else timedelta(0))
        and (r.departed_at <= at or not holding)
    ]


def place(candidates: Sequence[Run], at: datetime, station: str) -> Placement:
    """The owner of evidence from ``station`` dated ``at`` (the module's rules) among
    ``candidates`` (the section's runs), and its rivals; a pure function, so replay finds
    the same."""
    holding = [r for r in candidates if r.to_station == station and _holds(r, at)]
    departing = _departing(candidates, at, station, timedelta(0), bool(holding))
    after = [
        r
        for r in candidates
        if r.to_station == station
        and r.arrived_at is not None
        and r.arrived_at < at <= r.arrived_at + WINDOWS.after_arrival
    ]
    chosen: Run | None = None
    if departing:
        chosen = min(departing, key=lambda r: (abs(at - r.departed_at), -r.id))
    elif holding:
        chosen = min(holding, key=lambda r: (r.departed_at, r.id))
    elif after:
        chosen = max(after, key=lambda r: (r.arrived_at or at, r.id))
    arrived_lately = [
        r
        for r in candidates
        if r.to_station == station
        and r.arrived_at is not None
        and r.departed_at <= at
        and r.arrived_at < at <= r.arrived_at + REACH_AFTER_ARRIVAL
    ]
    late_departing = _departing(candidates, at, station, WINDOWS.clock_ahead, bool(holding))
    core = {r.id for r in (*holding, *departing)}
    rivals = {r.id: r for r in (*holding, *departing, *after, *arrived_lately, *late_departing)}
    certain = chosen is not None and (set(rivals) <= core or set(rivals) == {chosen.id})
    ordered = tuple(sorted(rivals.values(), key=lambda r: (r.departed_at, r.id)))
    return Placement(chosen, ordered, certain)


def owner(candidates: Sequence[Run], at: datetime, station: str) -> Run | None:
    """The run that evidence from ``station`` dated ``at`` belongs to (:func:`place`)."""
    return place(candidates, at, station).owner


def skewed_apart(earlier: Run, later: Run) -> bool:
    """``earlier``'s arrival is dated after ``later``'s departure, by no more than a clock may
    be ahead, but the server received the arrival first: the section was shown cleared when
    the train departed, and the overlap is the clocks', not two trains' (no conflict alarm;
    the runs still share the section by time, which ``occupancy.notes`` puts to a person)."""
    if earlier.arrived_at is None or earlier.arrival_received_at is None:
        return False
    if later.departure_received_at is None:
        return False
    overlap = earlier.arrived_at - later.departed_at
    return (
        timedelta(0) < overlap <= WINDOWS.clock_ahead
        and earlier.arrival_received_at <= later.departure_received_at
    )


def _owners(section: str, start: datetime, end: datetime) -> Select[Any]:
    """The query of the runs of ``section`` that could own evidence dated from ``start`` to
    ``end``, latest departure first (one filter for :func:`candidates` and :func:`spanning`)."""
    return (
        select(Run)
        .where(Run.section == section, Run.departed_at <= end + WINDOWS.before_departure)
        .where(
            or_(
                Run.arrived_at >= start - REACH_AFTER_ARRIVAL,
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
    return run.arrived_at >= at - REACH_AFTER_ARRIVAL


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
    """The run holding ``section`` at time ``at``, for evidence from a device at ``station``."""
    return placement_at(session, section, at, station).owner


def placement_at(session: Session, section: str, at: datetime, station: str) -> Placement:
    """:func:`place` among the section's runs for evidence dated ``at`` from ``station``.

    Under the section's lock the section's runs are read once for a whole group of evidence
    (exactly the candidates the query would give: same filter, order and limit)."""
    if section not in session.info.get(LOCKED, ()):
        return place(candidates(session, section, at, at), at, station)
    cache: dict[str, tuple[datetime, datetime, list[Run]]] = session.info.setdefault(
        SECTION_RUNS, {}
    )
    held = cache.get(section)
    if held is None or not held[0] <= at <= held[1]:
        start, end = at - SPAN_READ, at + SPAN_READ
        if held is not None:
            start, end = min(held[0], start), max(held[1], end)
        held = (start, end, spanning(session, section, start, end))
        cache[section] = held
    return place(eligible_at(held[2], at), at, station)


def eligible_at(runs: Sequence[Run], at: datetime) -> list[Run]:
    """Of ``runs`` (latest departure first), the candidates the query gives for ``at``."""
    return [r for r in runs if _eligible(r, at)][:CANDIDATES]


def spanning(session: Session, section: str, start: datetime, end: datetime) -> list[Run]:
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
