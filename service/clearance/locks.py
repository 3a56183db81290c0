"""The section lock: one writer decides a section at a time, and what is read under the lock
(the section's runs, ``attribution.run_at``) lives exactly as long as the lock does."""

from __future__ import annotations

from sqlalchemy import event, select
from sqlalchemy.orm import Session, SessionTransaction

from core.errors import NotFound
from core.models import Section
from service.clearance.attribution import LOCKED, SECTION_RUNS
from service.clearance.certainty import RECEIVED_RUNS


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
def _locks_released(session: Session, *_: object) -> None:
    # A rollback, even to a savepoint, may release the lock (and undo what was read under it).
    session.info.pop(LOCKED, None)
    session.info.pop(SECTION_RUNS, None)
    session.info.pop(RECEIVED_RUNS, None)


@event.listens_for(Session, "after_transaction_end")
def _transaction_ended(session: Session, transaction: SessionTransaction) -> None:
    # The end of the transaction itself (commit or rollback) releases the locks. Not the
    # release of a savepoint (SQLAlchemy's after_commit fires for that too), which keeps the
    # locks and what was read under them: else every event of a broker batch, each in its
    # savepoint, locked and read its section again.
    if transaction.parent is None:
        _locks_released(session)
