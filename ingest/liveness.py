"""A device's ``last_seen_at``, written at most once per granularity step, without a read.

The rule (the same live and on replay): an event moves ``last_seen_at`` to its ``occurred_at``
when that is more than ``LAST_SEEN_GRANULARITY`` past the stored value. It is one conditional
``UPDATE``; the worker remembers a committed lower bound of each device's value so that the
``UPDATE`` is not even sent when it could not match (the stored value only grows), which spares
a device sending many events a second a write for each one.
"""

from __future__ import annotations

import time
from datetime import datetime, timedelta

from sqlalchemy import Table, event, or_, update
from sqlalchemy.orm import Session

from core.models import Device

LAST_SEEN_GRANULARITY = timedelta(seconds=5)
# How long a remembered bound is trusted: ``depot replay`` resets the column underneath.
KNOWN_FOR_S = 30.0
_DEVICES: Table = Device.__table__  # type: ignore[assignment]
# (key hash, device id) -> (lower bound of the committed last_seen_at, when learnt)
_known: dict[tuple[str, str], tuple[datetime, float]] = {}


def _pending(session: Session) -> dict[tuple[str, str], datetime]:
    pending: dict[tuple[str, str], datetime] | None = session.info.get("depot_seen")
    if pending is None:
        pending = session.info["depot_seen"] = {}
    return pending


def learn_committed(session: Session) -> None:
    """After a commit: what this transaction proved about the devices' values is now durable."""
    now = time.monotonic()
    for ident, bound in session.info.pop("depot_seen", {}).items():
        old = _known.get(ident)
        if old is None or bound > old[0] or now - old[1] > KNOWN_FOR_S:
            _known[ident] = (bound, now)


def forget_pending(session: Session) -> None:
    session.info.pop("depot_seen", None)


event.listen(Session, "after_commit", learn_committed)
event.listen(Session, "after_rollback", forget_pending)


def touch(session: Session, device: Device, occurred: datetime, *, replaying: bool) -> None:
    """Apply the liveness rule for one event of ``device``."""
    ident = (device.key_hash or "", device.id)
    pending = _pending(session)
    bound = pending.get(ident)
    if bound is None and not replaying:
        known = _known.get(ident)
        if known is not None and time.monotonic() - known[1] < KNOWN_FOR_S:
            bound = known[0]
    if bound is not None and occurred <= bound + LAST_SEEN_GRANULARITY:
        return  # the stored value is within one step of this event already
    threshold = occurred - LAST_SEEN_GRANULARITY
    moved = session.execute(
        update(_DEVICES)
        .where(
            _DEVICES.c.id == device.id,
            or_(_DEVICES.c.last_seen_at.is_(None), _DEVICES.c.last_seen_at < threshold),
        )
        .values(last_seen_at=occurred)
    )
    # Moved: the value is now ``occurred``; not moved: it was at least ``threshold`` already.
    new_bound = occurred if moved.rowcount else threshold  # type: ignore[attr-defined]
    if bound is None or new_bound > bound:
        pending[ident] = new_bound


def snapshot_pending(session: Session) -> dict[tuple[str, str], datetime]:
    return dict(_pending(session))


def restore_pending(session: Session, saved: dict[tuple[str, str], datetime]) -> None:
    """After a savepoint rolled back: what it wrote about liveness is gone with it."""
    session.info["depot_seen"] = dict(saved)
