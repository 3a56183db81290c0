"""Runs: departure opens one, arrival closes and decides it; evidence re-evaluates; people act."""

from __future__ import annotations

from datetime import datetime
from typing import Any

from sqlalchemy.orm import Session

from core.models import Section
from service.clearance import attribution, certainty, occupancy, unseen
from service.clearance.attribution import forget_runs, placement_at, side_of
from service.clearance.doubts import (
    blocking_first,
    not_ahead,
    time_contradictions,
    train_contradictions,
)
from service.clearance.evidence import gather
from service.clearance.locks import lock_section
from service.clearance.models import Run
from service.clearance.refusals import ACTION_STATES
from service.clearance.rules import (
    Verdict,
    decide,
    departure_opens_sweep,
    describe_sweep,
    next_state,
    redecided_state,
)
from service.clearance.sweeps import SYSTEM, record_sweep

BUSY_STATES = ("occupied", "awaiting_confirmation", "review", "alarm", "blocked", "awaiting_sweep")
__all__ = [
    "ACTION_STATES",
    "SYSTEM",
    "attach",
    "close_run",
    "evaluate",
    "lock_section",
    "open_run",
]


def set_state(section: Section, state: str, at: datetime) -> None:
    # A state's time never goes back before one already shown (a late departure, a device
    # clock behind, late evidence after a dispatcher's decision).
    if section.state != state:
        section.state = state
        section.state_since = occupancy.later(section.state_since, at)


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
    """``train_departed``: the train takes the block, or it is a conflict (it departed into a
    section not cleared) and waits behind the section's current run (``occupancy``).

    Into a section awaiting a sweep the train is the sweep run: no conflict, it holds the
    section and remembers the run it sweeps. ``received`` is when the server received the
    departure: the departure-side devices' liveness is judged then. The evidence that belongs
    to the new run joins it, and an arrival of this train that came first closes it.
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
    session.add(run)
    forget_runs(session, section.id)
    _explain(session, section, run, not_ahead(at, received))
    busy = section.state in BUSY_STATES
    if departure_opens_sweep(section.state) and occupancy.may_sweep(session, section, run):
        run.sweep, run.sweep_of = True, section.current_run_id
    else:
        run.conflict = occupancy.conflict_words(session, section, run, busy)
    if run.conflict and busy:
        run.status = "conflict"  # waits behind the current run
    else:
        section.current_run_id = run_id
    set_state(section, "alarm" if run.conflict else "occupied", not_ahead(at, received))
    session.flush()
    out: dict[str, Any] = {"run": run_id}
    if run.conflict:
        out.update(conflict=True, detail=run.conflict)
    if run.sweep:
        out.update(sweep=True, sweep_of=run.sweep_of)
    out["adopted_evidence"] = _take_evidence(session, run, section, received)
    arrival = _take_arrival(session, run, section)
    if arrival is not None:
        out["arrival"] = arrival
    return {**out, "section_state": section.state}


def _explain(session: Session, section: Section, run: Run, at: datetime) -> None:
    """The departure of a train whose arrival came first, when nobody had seen it enter: the
    unseen-entry run gives the arrival back (``unseen``). Removed (nobody acted on it), it no
    longer holds the section: the train that waited behind it, or this departure, does."""
    found = unseen.explained_by(session, run)
    if found is None:
        return
    held = section.current_run_id == found.id
    if unseen.release(session, found) and held:
        session.flush()
        section.current_run_id = None
        section.state = "free"  # only the unseen arrival had closed it; this departure decides
        promote_conflict(session, section, at)
    session.flush()
    forget_runs(session, section.id)


def _take_arrival(session: Session, run: Run, section: Section) -> dict[str, Any] | None:
    """An arrival of this train that reached depot first closes the run just opened: kept
    without a run, or taken back from the run it closed for want of this departure (which is
    then in the section again, and takes an arrival of its own train if one came)."""
    early = occupancy.early_arrival(session, run, before=run.id)
    if early is not None:
        return _arrive(session, run, section, early, early.received_at)
    other = occupancy.mistaken_arrival(session, section, run)
    if other is None:
        return None
    assert other.arrived_at is not None and other.arrival_train is not None
    arrival = _Arrival(other.arrival_id, other.arrived_at, other.arrival_received_at, run.train)
    occupancy.reopen(other)
    forget_runs(session, section.id)
    session.flush()
    result = _arrive(session, run, section, arrival, arrival.received_at)
    own = occupancy.early_arrival(session, other, before=run.id)
    if own is not None:
        _arrive(session, other, section, own, own.received_at)
    return result


def _take_evidence(session: Session, run: Run, section: Section, received: datetime | None) -> int:
    """The evidence that belongs to a run just opened joins it; the earlier runs it came from,
    and those that shared the section with it, are decided again (they may owe a person a
    look now)."""
    taken, again = attribution.reclaim(session, run)
    session.flush()
    again |= {o.id for o in occupancy.overlapping(session, run)}
    for other_id in sorted(again):
        other = session.get(Run, other_id)
        if other is not None and other.arrived_at is not None:
            evaluate(session, other, section, received=received)
    return taken


def close_run(
    session: Session,
    section_id: str,
    station: str,
    train: str,
    at: datetime,
    *,
    received: datetime | None = None,
    arrival_id: int | None = None,
) -> dict[str, Any]:
    """``train_arrived``: the open run with this train number (else the first that departed)
    arrives at the far station and is decided; the arrival-side devices' liveness is judged
    at ``received``, when the server got the arrival. An arrival that finds no run is kept:
    a departure reported late takes it."""
    section = lock_section(session, section_id)
    run = occupancy.arriving_run(session, section, station, train)
    if run is None:
        other = occupancy.arriving_run(session, section, _other_end(section, station), train)
        if other is not None:
            return {
                "run": other.id,
                "warning": f"arrival reported at {station}, but run {other.id} goes to"
                f" {other.to_station}",
            }
        arrival = _Arrival(arrival_id, at, received, train, station)
        return _unseen_arrival(session, section, arrival)
    arrival = _Arrival(arrival_id, at, received, train, station)
    return _arrive(session, run, section, arrival, received)


def _unseen_arrival(session: Session, section: Section, arrival: _Arrival) -> dict[str, Any]:
    """An arrival that found no run: kept for a departure that reaches depot later, and until
    then a train nobody saw enter — its own run, in review (or waiting behind the section's
    current run), never shown as clear (``unseen``)."""
    kept = (
        f"no train was running in section {section.id}; the arrival is kept for a departure"
        " that reaches depot later"
    )
    if arrival.id is None:
        return {"run": None, "warning": kept}
    train, received = arrival.body["train"], arrival.received_at
    run = unseen.open_unseen(section, arrival.station, train, arrival.occurred_at, received,
                             arrival.id)  # fmt: skip
    session.add(run)
    forget_runs(session, section.id)
    if section.state == "free":
        section.current_run_id = run.id
        set_state(section, "occupied", not_ahead(arrival.occurred_at, received))
    else:
        run.status = "conflict"  # waits behind the current run, like a train departed into it
    session.flush()
    evaluate(session, run, section, received=received)
    return {
        "run": None,
        "warning": f"{kept}; until then train {train} is a train nobody saw enter the section"
        f" (run {run.id}), for a person to look at",
        "unseen_run": run.id,
        "section_state": section.state,
    }


class _Arrival:
    """What a run keeps of its ``train_arrived`` (a raw event stored earlier has the same)."""

    def __init__(
        self,
        ident: int | None,
        at: datetime,
        received: datetime | None,
        train: str,
        station: str = "",
    ) -> None:
        self.id, self.occurred_at, self.received_at = ident, at, received
        self.body, self.station = {"train": train}, station


def _other_end(section: Section, station: str) -> str:
    return section.from_station if station == section.to_station else section.to_station


def _arrive(
    session: Session, run: Run, section: Section, arrival: Any, received: datetime | None
) -> dict[str, Any]:
    run.arrived_at, run.arrival_received_at = arrival.occurred_at, arrival.received_at
    run.arrival_train, run.arrival_id = arrival.body.get("train"), arrival.id
    forget_runs(session, section.id)
    if run.status == "running":
        run.status = "arrived"  # a waiting run keeps "conflict" until it is the current run
    return evaluate(session, run, section, received=received)


def evaluate(
    session: Session, run: Run, section: Section, *, received: datetime | None = None
) -> dict[str, Any]:
    """Decide an arrived run from its evidence; the section follows when the run holds it.

    The first decision dates the section's state at the arrival; a re-decision (late
    evidence, ``received`` by the server then) after a decision was shown changes the section
    only for something new that a person must see (``rules.redecided_state``), dated when it
    came — never before the decision already shown.
    """
    first, before = run.decided_at is None, list(run.reasons or [])
    previous = run.verdict
    notes = [*time_contradictions(run), *train_contradictions(run), *occupancy.notes(session, run)]
    gathered = gather(session, run, section)
    decision = decide(gathered.evidence)
    verdict, reasons = blocking_first(decision, notes)
    if run.sweep and run.sweep_of is not None:
        reasons.append(describe_sweep(run.id, run.sweep_of, verdict))
    run.verdict, run.reasons, run.evidence = verdict, reasons, gathered.summary
    if first:
        run.decided_at = run.arrived_at
    at = not_ahead((run.arrived_at or run.departed_at) if first else received, received)
    if run.sweep and run.sweep_of is not None:
        record_sweep(session, run, section)
    if section.current_run_id == run.id and run.status != "conflict":
        if first:
            state = next_state(section.state, verdict, section.mode)
        else:
            new = verdict != "complete" and bool(set(reasons) - set(before))
            state = redecided_state(section.state, verdict, section.mode, new)
        set_state(section, state, at)
        if section.state == "free":
            promote_conflict(session, section, at)
    elif verdict == "incomplete" and previous != "incomplete":
        # Late proof that an earlier train lost cars: they may still stand in the section the
        # next train now holds (clearance.md: late evidence of incompleteness raises the alarm).
        set_state(section, next_state(section.state, verdict, section.mode), at)
    session.flush()
    return {"run": run.id, "verdict": verdict, "reasons": reasons, "section_state": section.state}


def promote_conflict(session: Session, section: Section, at: datetime) -> None:
    """When the current run is resolved, the first train waiting behind it (a conflict) holds
    the section: still running (``occupied``), or arrived and decided — then the section
    follows that decision, which is never ``complete`` for a conflict (a person must look).
    A fault run nobody decided yet (``faults``) holds it in ``review``."""
    waiting = occupancy.next_waiting(session, section)
    if waiting is None:
        return
    section.current_run_id = waiting.id
    if occupancy.is_fault(waiting):  # an event that could not be processed: a person looks
        set_state(section, "review", at)
        return
    if waiting.arrived_at is None:
        waiting.status = "running"
        set_state(section, "occupied", at)
        return
    waiting.status = "arrived"
    verdict: Verdict = waiting.verdict or "undetermined"  # type: ignore[assignment]
    set_state(section, next_state("occupied", verdict, section.mode), at)


def attach(
    session: Session,
    row: Any,
    section_id: str,
    station: str,
    at: datetime,
    *,
    received: datetime | None = None,
) -> dict[str, Any]:
    """Attach a piece of evidence to the run it belongs to (``attribution``); re-decide the run
    if it has arrived (``received``: when the server got the evidence)."""
    section = lock_section(session, section_id)
    # Decided before the row joins the session: no insert and update for one piece (a group of
    # readings then goes in with one insert, when the session next flushes).
    with session.no_autoflush:
        placement = placement_at(session, section_id, at, station)
        run = placement.owner
        row.run_id = None if run is None else run.id
        row.side = None if run is None else side_of(run, station)
        # Evidence a wrong clock may have misplaced is a doubt for every run it may be
        # (certainty); asked before the row joins the session, so its query flushes no row.
        doubted = certainty.doubted_runs(session, section_id, row, received, placement)
    session.add(row)
    for other in doubted:
        evaluate(session, other, section, received=received)
    answer = attached_answer(section_id, run, station)
    if answer is not None:
        return answer
    assert run is not None  # no answer yet: the run has arrived and is decided again
    reevaluated = evaluate(session, run, section, received=received)
    return {"run": run.id, "side": row.side, "reevaluated": reevaluated}


def attached_answer(section_id: str, run: Run | None, station: str) -> dict[str, Any] | None:
    """What :func:`attach` answers for evidence from ``station`` attached to ``run``, unless
    the run has arrived (None: its re-decision is part of the answer)."""
    if run is None:
        return {"run": None, "note": f"no run in section {section_id} at that time; evidence kept"}
    if run.arrived_at is not None:
        return None
    return {"run": run.id, "side": side_of(run, station)}
