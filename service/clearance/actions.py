"""A dispatcher's actions on a run (``clear``, ``keep_blocked``, ``sweep``): the one way a
person changes a section's state, each audited once (append-only)."""

from __future__ import annotations

from collections.abc import Sequence
from datetime import datetime

from sqlalchemy.orm import Session

from core.auth import Principal
from core.errors import NotFound
from service.clearance.attribution import forget_runs
from service.clearance.evidence import gather
from service.clearance.locks import lock_section
from service.clearance.models import AuditRecord, Run
from service.clearance.occupancy import is_fault
from service.clearance.refusals import ACTION_STATES, check_action
from service.clearance.revision import check_seen
from service.clearance.service import promote_conflict, set_state


def act(
    session: Session,
    run_id: int,
    action: str,
    reason: str,
    actor: Principal,
    at: datetime,
    *,
    audit: bool = True,
    seen: Sequence[Sequence[str]] = (),
) -> AuditRecord | None:
    """A dispatcher's ``clear``, ``keep_blocked`` or ``sweep`` on the section's current, arrived
    run. ``sweep`` only where nothing proves the section empty (alarm, review, blocked); a
    ``clear`` of a section awaiting its sweep is audited as a force-clear.

    The one way to act on a run: the API and the review form both call it. An action that
    asks for the state the section is already in (a second ``clear``, a double click) is
    refused (409) before anything is written, so the audit holds each decision once.

    ``seen``: the looks at the run the person acted on, each the revisions it may be
    (``revision``; an ``If-Match`` may list several); when given, a run that has changed
    since is refused (409). The endpoints pass it; a replay passes none.
    """
    run = session.get(Run, run_id)
    if run is None:
        raise NotFound(f"run {run_id} does not exist")
    section = lock_section(session, run.section)
    if seen:
        # The run and section as committed now: evidence may have come while the lock was
        # awaited, and a screen may have read them before this transaction took the lock.
        session.flush()
        session.refresh(run)
        session.refresh(section)
        check_seen(session, run, section, seen)
    missing = check_action(session, run, section, action, at)
    before = section.state
    gathered = gather(session, run, section)
    set_state(section, ACTION_STATES[action], at)
    run.auto = False
    unarrived = run.arrived_at is None and not is_fault(run)  # a fault run is no train
    if unarrived and not (missing and action == "keep_blocked"):
        # Released without an arrival: it holds the section no more. A silent section's
        # train kept blocked still does: its arrival, if it ever comes, closes its run.
        run.status = "overtaken"
        forget_runs(session, section.id)
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
                **({"arrival_missing": missing} if missing else {}),
            },
        )
        session.add(record)
    session.flush()
    return record
