"""Keeping the rows a group's derivations load, so that the next event finds them in memory.

SQLAlchemy's identity map holds unmodified objects only weakly: a row a derivation loaded and
let go of (the section it locked, a run it looked at) is gone when the next event of the same
transaction asks for it, and ``session.get`` reads it again. A group of 30 events of one
section then reads the locked section 30 times. Inside :func:`holding` every object the
session loads or inserts is kept until the block ends, which makes those look-ups free: the
objects are those of the running transaction, current because the section lock keeps other
writers out (and SQLAlchemy still expires them on a rollback or commit as usual).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from sqlalchemy import event
from sqlalchemy.orm import Session

_HELD = "depot_held_objects"


@contextmanager
def holding(session: Session) -> Iterator[None]:
    """Keep every object ``session`` loads or inserts referenced until the block ends."""
    outer = _HELD in session.info
    if not outer:
        session.info[_HELD] = []
    try:
        yield
    finally:
        if not outer:
            session.info.pop(_HELD, None)


def held(session: Session) -> int:
    """How many objects are held (for tests)."""
    return len(session.info.get(_HELD, ()))


def _keep(session: Session, instance: Any) -> None:
    kept: list[Any] | None = session.info.get(_HELD)
    if kept is not None:
        kept.append(instance)


event.listen(Session, "loaded_as_persistent", _keep)
event.listen(Session, "pending_to_persistent", _keep)
