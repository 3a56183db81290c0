"""Several runs in one block section: a train that departed into a section not cleared, which
arrival is whose, and the words that make every such run a matter for a person.

The section's *current* run is the one its state describes and the dispatcher acts on. A train
departing while the section is not cleared (not ``free``, not awaiting its sweep) is a
*conflict*: it is recorded with ``status`` ``conflict`` and waits behind the current run — it
arrives, collects its evidence and is decided like any run, but the section follows it only
when the runs ahead of it are resolved (``promote``). Its decision is never ``complete``
without a person (``Run.conflict`` says why), nor is the decision of a run that shared the
section with another train: by time alone their evidence cannot be told apart.
"""

from __future__ import annotations

from datetime import datetime

from sqlalchemy import and_, or_, select
from sqlalchemy.orm import Session

from core.models import Device, Section
from core.schemas import format_instant
from ingest.models import RawEvent
from service.clearance.attribution import IN_SECTION, skewed_apart
from service.clearance.models import Run

# The status of a *fault run*: an event naming the section whose derivation failed
# (``service.clearance.faults``). It is no train: never attached evidence, never in the section
# by time (no arrival, and not ``IN_SECTION``), but it waits for a person like a conflict does.
FAULT = "fault"


def is_fault(run: Run) -> bool:
    return run.status == FAULT


def is_open(run: Run, section: Section) -> bool:
    """Not resolved yet: waiting behind the current run, or current in a section not free."""
    if run.status == "conflict":
        return True
    return run.id == section.current_run_id and section.state != "free"


def conflict_words(session: Session, section: Section, run: Run, busy: bool) -> str | None:
    """Why ``run`` departed into a section that was not cleared, or None when it was.

    ``busy``: the section's state says it is not cleared. A departure dated while another
    train held the section by device time is a conflict too (it reached depot late, after the
    section had been freed)."""
    holder = session.get(Run, section.current_run_id) if section.current_run_id else None
    if busy and section.state == "awaiting_sweep" and holder is not None:
        return (
            f"train {run.train} departed into section {section.id} at"
            f" {format_instant(run.departed_at)}, before train {holder.train} (run {holder.id})"
            " had left it: it cannot be the sweep train asked for; two trains in one section,"
            " a person must look"
        )
    if busy:
        held = f" (run {holder.id}, train {holder.train})" if holder else ""
        return (
            f"train {run.train} departed into section {section.id}, which is {section.state}"
            f" and was not cleared{held}: a person must look"
        )
    other = holder_at(session, section, run)
    if other is not None and not skewed_apart(other, run):  # a clock ahead: not two trains
        return (
            f"train {run.train} departed into section {section.id} while train {other.train}"
            f" (run {other.id}) was in it, so the section was not cleared: a person must look"
        )
    behind = follower_at(session, run)
    if behind is None:
        return None
    return (
        f"train {run.train} departed into section {section.id} at"
        f" {format_instant(run.departed_at)}, and train {behind.train} (run {behind.id})"
        f" departed into it at {format_instant(behind.departed_at)} before train {run.train} was"
        " seen to arrive: two trains in one section; a person must look"
    )


def follower_at(session: Session, run: Run) -> Run | None:
    """A run that departed into the section after ``run`` (a departure that reached depot
    late) while ``run`` may still have been in it: before its arrival, if one came first
    (``early_arrival``), else at any time — an arrival not seen proves nothing."""
    early = early_arrival(session, run, before=run.id)
    query = select(Run).where(Run.section == run.section, Run.id != run.id)
    query = query.where(Run.departed_at > run.departed_at, Run.status != FAULT)
    if early is not None:
        query = query.where(Run.departed_at < early.occurred_at)
    return session.scalar(query.order_by(Run.departed_at, Run.id).limit(1))


def may_sweep(session: Session, section: Section, run: Run) -> bool:
    """Whether ``run``, departing into a section awaiting its sweep, is the sweep train: it
    must have departed after the state that asks for the sweep began — after the swept train
    left the section (its arrival; its departure if it never arrived) — and while no other
    train was in it. A late departure dated while the swept train was inside is a conflict."""
    swept = session.get(Run, section.current_run_id) if section.current_run_id else None
    if swept is None:
        return holder_at(session, section, run) is None
    began = swept.arrived_at or swept.departed_at
    return run.departed_at >= began and holder_at(session, section, run) is None


def holder_at(session: Session, section: Section, run: Run) -> Run | None:
    """Another run in the section at ``run``'s departure, by device time."""
    at = run.departed_at
    return session.scalar(
        select(Run)
        .where(Run.section == section.id, Run.id != run.id, Run.departed_at <= at)
        .where(
            or_(
                Run.arrived_at > at,
                and_(Run.arrived_at.is_(None), Run.status.in_(IN_SECTION)),
            )
        )
        .order_by(Run.departed_at.desc())
        .limit(1)
    )


def overlapping(session: Session, run: Run) -> list[Run]:
    """Other runs that were in the section at the same time as ``run`` (by device time)."""
    query = select(Run).where(Run.section == run.section, Run.id != run.id)
    if run.arrived_at is not None:
        query = query.where(Run.departed_at < run.arrived_at)
    query = query.where(
        or_(
            Run.arrived_at > run.departed_at,
            and_(Run.arrived_at.is_(None), Run.status.in_(IN_SECTION)),
        )
    )
    return list(session.scalars(query.order_by(Run.departed_at, Run.id)))


def notes(session: Session, run: Run) -> list[str]:
    """The reasons, derived from the runs, that keep ``run`` from ``complete``: it departed
    into a section not cleared, or shared the section with another train."""
    found = [run.conflict] if run.conflict else []
    for other in overlapping(session, run):
        if other.sweep_of == run.id or run.sweep_of == other.id:
            continue
        found.append(
            f"train {other.train} (run {other.id}) was in section {run.section} at the same"
            " time: which evidence is whose cannot be told by time; a person must look"
        )
    return found


def arriving_run(session: Session, section: Section, station: str, train: str) -> Run | None:
    """The open run a ``train_arrived`` at ``station`` closes: the one with the reported train
    number, else the first that departed (single track: no overtaking) — whose decision then
    keeps the mismatch of numbers (``train_contradictions``)."""
    runs = session.scalars(
        select(Run)
        .where(Run.section == section.id, Run.arrived_at.is_(None), Run.to_station == station)
        .where(Run.status.in_(IN_SECTION))
        .order_by(Run.departed_at, Run.id)
    ).all()
    waiting = [r for r in runs if is_open(r, section)]
    return next((r for r in waiting if r.train == train), waiting[0] if waiting else None)


def early_arrival(session: Session, run: Run, before: int) -> RawEvent | None:
    """An arrival of this train that reached depot before its departure (derived before the
    event ``before``, and nobody took it)."""
    used = select(Run.arrival_id).where(Run.section == run.section, Run.arrival_id.is_not(None))
    rows = session.scalars(
        select(RawEvent)
        .join(Device, Device.id == RawEvent.device_id)
        .where(RawEvent.kind == "train_arrived", RawEvent.section == run.section)
        .where(RawEvent.id < before, RawEvent.occurred_at >= run.departed_at)
        .where(Device.station == run.to_station, RawEvent.id.not_in(used))
        .order_by(RawEvent.occurred_at, RawEvent.id)
    )
    return next((raw for raw in rows if raw.body.get("train") == run.train), None)


def mistaken_arrival(session: Session, section: Section, run: Run) -> Run | None:
    """An open run that an arrival of *this* train closed because this train's departure had
    not reached depot yet (the arrival named this train number, not the run's), and that no
    person has acted on: the arrival is this run's."""
    runs = session.scalars(
        select(Run)
        .where(Run.section == section.id, Run.id != run.id, Run.arrival_train == run.train)
        .where(Run.train != run.train, Run.arrived_at >= run.departed_at, Run.auto.is_(True))
        .order_by(Run.arrived_at, Run.id)
    )
    return next((r for r in runs if is_open(r, section)), None)


def reopen(run: Run) -> None:
    """Take a mistaken arrival back from ``run``: it is in the section again, undecided."""
    run.arrived_at = run.arrival_received_at = run.decided_at = None
    run.arrival_train, run.arrival_id, run.verdict = None, None, None
    run.reasons, run.evidence = [], {}
    if run.status == "arrived":
        run.status = "running"


def overtaken(session: Session, run: Run) -> bool:
    """A train that departed after this one has arrived out of the section: on single track it
    cannot have passed it, so this run's missing arrival is for a person to judge (and a
    dispatcher may act on the run although its arrival never came). The arrival of a train
    *ahead* of it proves nothing of the kind: this train may well still be in the section."""
    return (
        session.scalar(
            select(Run.id)
            .where(Run.section == run.section, Run.id != run.id)
            .where(Run.departed_at > run.departed_at, Run.arrived_at > run.departed_at)
            .limit(1)
        )
        is not None
    )


def next_waiting(session: Session, section: Section) -> Run | None:
    """The run that takes the section when its current run is resolved: the first that
    departed of those waiting behind it, or the first fault run nobody has decided yet."""
    current = section.current_run_id or 0  # raw ids start at 1 (``!= NULL`` matches nothing)
    undecided = and_(Run.status == FAULT, Run.auto.is_(True), Run.id != current)
    return session.scalar(
        select(Run)
        .where(Run.section == section.id, or_(Run.status == "conflict", undecided))
        .order_by(Run.departed_at, Run.id)
        .limit(1)
    )


def later(a: datetime | None, b: datetime) -> datetime:
    """The later of two instants (``a`` may be unknown): a state's time never goes back."""
    return b if a is None else max(a, b)
