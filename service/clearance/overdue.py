"""A run whose arrival never comes, with no train behind it: when a dispatcher may act on it.

clearance.md refuses an action "while the run has not arrived", and allows one on a run a
later train overtook (``occupancy.overtaken``). A train that never arrives and has no train
behind it left the dispatcher a dead 409 for ever. Once the section has been *silent* for
:attr:`OverdueRules.silent_after` — no event naming it (a departure, an arrival, any evidence)
received by the server — the run is *overdue*: a dispatcher may keep the section blocked or ask
for a sweep train, with a reason, audited; a ``clear`` only after it is blocked (two acts, two
reasons). Nothing happens by itself: the section stays ``occupied`` until a person acts, and is
never freed automatically. Silence is judged by server receive times up to the moment of the
action, so replay judges it the same.
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime, timedelta

from sqlalchemy import func, select
from sqlalchemy.orm import Session

from core.schemas import format_instant
from ingest.models import RawEvent
from service.clearance.models import Run


@dataclass(frozen=True)
class OverdueRules:
    """When a run that has not arrived is for a dispatcher to judge.

    Attributes
    ----------
    silent_after
        How long the section must have been silent (no event naming it received) before a
        dispatcher may act on its train that never arrived. Longer than any train takes
        through a section, so that a train still running normally is never acted on: the
        section speaking again (the train's own evidence) restarts the wait.
    """

    silent_after: timedelta = timedelta(hours=2)


OVERDUE = OverdueRules()


def last_heard(session: Session, section: str, at: datetime) -> datetime | None:
    """When the server last received an event naming the section, up to ``at``."""
    return session.scalar(
        select(func.max(RawEvent.received_at)).where(
            RawEvent.section == section, RawEvent.received_at <= at
        )
    )


def overdue(session: Session, run: Run, at: datetime) -> str | None:
    """Why ``run`` may be acted on although it has not arrived (in a dispatcher's words), or
    None: it arrived, or its section has not been silent long enough at server time ``at``."""
    if run.arrived_at is not None:
        return None
    heard = last_heard(session, run.section, at) or run.departure_received_at or run.departed_at
    if at - heard < OVERDUE.silent_after:
        return None
    hours = OVERDUE.silent_after.total_seconds() / 3600
    return (
        f"no arrival of train {run.train} (departed {format_instant(run.departed_at)}) came:"
        f" section {run.section} has been silent since {format_instant(heard)}, more than"
        f" {hours:g} h; the train has not arrived and nothing proves the section empty"
    )


def waiting_words() -> str:
    """What a refused action on a train still inside says about when it may be acted on."""
    hours = OVERDUE.silent_after.total_seconds() / 3600
    return (
        f"a dispatcher may act on it once the section has been silent for {hours:g} h"
        " (no event naming it), or once a train behind it has arrived"
    )
