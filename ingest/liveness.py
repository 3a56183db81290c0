"""Device liveness: when the server last heard from a device, and the one staleness rule.

Liveness is judged by the times the server *received* a device's events (protocol.md), never
by the device's own ``occurred_at``: a device clock set to 2030 cannot keep itself alive, and
one running hours behind is not silent while it talks. (The device's times still order its
evidence.) Over MQTT, which carries no broker time, the receive time is the bridge's read
bounded by the event's own time (``ingest.multi_store``): there the clock can make a device
look silent, never alive. A device is **stale** when nothing from it was received within
``DEPOT_HEARTBEAT_S``; a decommissioned device is not expected to speak, so it is never stale
(:func:`is_stale`).

``last_seen_at`` is written at most once per granularity step, without a read. The rule (the
same live and on replay): an event moves ``last_seen_at`` to its ``received_at`` when that is
more than ``LAST_SEEN_GRANULARITY`` past the stored value. It is one conditional ``UPDATE``;
the worker remembers a committed lower bound of each device's value so that the ``UPDATE`` is
not even sent when it could not match (the stored value only grows), which spares a device
sending many events a second a write for each one. The stored value may thus lag by one step:
a device looks stale at most that much early, never late.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from datetime import datetime, timedelta

from sqlalchemy import ColumnElement, Table, bindparam, event, func, or_, select, update
from sqlalchemy.orm import Session

from core.models import Device
from core.settings import get_settings
from ingest.models import RawEvent

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


def touch(session: Session, device: Device, received: datetime, *, replaying: bool) -> None:
    """Apply the liveness rule for one event of ``device``, received by the server at
    ``received`` (the raw event's ``received_at``: the same on replay)."""
    ident = (device.key_hash or "", device.id)
    pending = _pending(session)
    bound = pending.get(ident)
    if bound is None and not replaying:
        known = _known.get(ident)
        if known is not None and time.monotonic() - known[1] < KNOWN_FOR_S:
            bound = known[0]
    if bound is not None and received <= bound + LAST_SEEN_GRANULARITY:
        return  # the stored value is within one step of this event already
    threshold = received - LAST_SEEN_GRANULARITY
    moved = session.execute(
        _TOUCH, {"device": device.id, "threshold": threshold, "seen_at": received}
    )
    if moved.rowcount:  # type: ignore[attr-defined]
        new_bound = received
    else:
        # Not moved: the value is at least ``threshold`` (another worker, or an earlier event,
        # put it there). ``threshold`` alone as the bound would send the update again for
        # every later event of this device (received a moment later, so past it): 500 for a
        # batch. The stored value itself is a bound that spares them.
        stored = session.scalar(_LAST_SEEN, {"device": device.id})
        new_bound = threshold if stored is None else max(stored, threshold)
    if bound is None or new_bound > bound:
        pending[ident] = new_bound


# Built once: the statements of constant shape, with the values bound per call.
_TOUCH = (
    update(_DEVICES)
    .where(
        _DEVICES.c.id == bindparam("device"),
        or_(
            _DEVICES.c.last_seen_at.is_(None),
            _DEVICES.c.last_seen_at < bindparam("threshold", type_=_DEVICES.c.last_seen_at.type),
        ),
    )
    .values(last_seen_at=bindparam("seen_at", type_=_DEVICES.c.last_seen_at.type))
)
_LAST_SEEN = select(_DEVICES.c.last_seen_at).where(_DEVICES.c.id == bindparam("device"))


_LATER = "depot_touch_later"


def seen(session: Session, device: Device, received: datetime, *, replaying: bool) -> None:
    """:func:`touch` now, or at the end of the :func:`touched_at_end` block around it."""
    later: list[tuple[Device, datetime]] | None = session.info.get(_LATER)
    if later is None or replaying:
        touch(session, device, received, replaying=replaying)
    else:
        later.append((device, received))


@contextmanager
def touched_at_end(session: Session) -> Iterator[None]:
    """Apply the liveness rule of the events derived in the block when it ends, in device
    order: the devices' rows are then locked after every section a derivation locked, and in
    the same order by every transaction, so that two groups (or a group and a single event)
    never wait for each other's device and section rows in a cycle (a deadlock, which costs
    the database's deadlock timeout and a retry of every event of the group). Per device the
    events keep their order, so the stored values are those of touching them one by one. On
    an exception nothing is applied (the transaction is rolled back anyway)."""
    if _LATER in session.info:
        yield  # an outer block applies them
        return
    later: list[tuple[Device, datetime]] = []
    session.info[_LATER] = later
    try:
        yield
    finally:
        session.info.pop(_LATER, None)
    # The same (device, instant) twice changes nothing the first did not (a batch's events
    # share their instant of receipt): touched once.
    once = {(device.id, received): (device, received) for device, received in later}
    for device, received in sorted(once.values(), key=lambda item: item[0].id):
        touch(session, device, received, replaying=False)


def snapshot_pending(session: Session) -> dict[tuple[str, str], datetime]:
    return dict(_pending(session))


def restore_pending(session: Session, saved: dict[tuple[str, str], datetime]) -> None:
    """After a savepoint rolled back: what it wrote about liveness is gone with it."""
    session.info["depot_seen"] = dict(saved)


def heartbeat_limit() -> timedelta:
    """How long a device may be silent before it is stale (``DEPOT_HEARTBEAT_S``)."""
    return timedelta(seconds=get_settings().heartbeat_s)


def silent(last_received: datetime | None, now: datetime) -> bool:
    """The staleness rule: nothing received from the device within the heartbeat period."""
    return last_received is None or now - last_received > heartbeat_limit()


def is_stale(device: Device, now: datetime) -> bool | None:
    """Whether ``device`` is stale at server time ``now``; ``None`` once it is decommissioned
    (from then on no heartbeat is expected, so its silence means nothing)."""
    if device.decommissioned_at is not None and device.decommissioned_at <= now:
        return None
    return silent(device.last_seen_at, now)


# The id of the raw event being derived: a decision reads liveness only from the raw events
# stored up to it (:func:`heard_up_to`).
_HEARD_UPTO = "depot_heard_upto"


@contextmanager
def heard_up_to(session: Session, raw_id: int | None) -> Iterator[None]:
    """Within the block, liveness is read from the raw events stored up to ``raw_id``.

    A receive time can be earlier than the moment its row is stored: JetStream gives the
    broker's time, and a bridge's backlog is delivered after a restart. Read from every row, a
    decision taken live (before such a row was stored) and the same decision on replay (which
    finds it stored) would differ. Bounded by the derived event's own id, both read the rows
    stored before it: the same ones (but for a row whose transaction had not yet committed).
    """
    before = session.info.get(_HEARD_UPTO)
    session.info[_HEARD_UPTO] = raw_id
    try:
        yield
    finally:
        session.info[_HEARD_UPTO] = before


def _stored_so_far(session: Session) -> list[ColumnElement[bool]]:
    bound: int | None = session.info.get(_HEARD_UPTO)
    return [] if bound is None else [RawEvent.id <= bound]


def last_received_before(session: Session, device_id: str, at: datetime) -> datetime | None:
    """When the server last received anything from the device up to server time ``at``
    (exact, from the raw events: deterministic on replay)."""
    return session.scalar(
        select(func.max(RawEvent.received_at)).where(
            RawEvent.device_id == device_id, RawEvent.received_at <= at, *_stored_so_far(session)
        )
    )


@dataclass(frozen=True)
class Silence:
    """A time the server heard nothing from a device for longer than the heartbeat period.

    ``heard`` is when it last heard from it before (an event received, or the device's
    registration); ``until`` the next event received, or the end of the window asked about
    (then ``ongoing``).
    """

    device: str
    heard: datetime
    until: datetime
    ongoing: bool


def silent_during(
    session: Session, device: Device, start: datetime, end: datetime
) -> Silence | None:
    """The first silence of ``device`` longer than the heartbeat period at any time between
    server times ``start`` and ``end``, or None when it was heard throughout.

    The window is cut to the time the device was in service: it owes nothing before it was
    registered, nor once decommissioned. Its registration starts its first silence, and a
    device never heard from by the window's end is silent whatever the window's length: it
    has never shown that it works.
    """
    start = max(start, device.created_at)
    if device.decommissioned_at is not None:
        end = min(end, device.decommissioned_at)
    if end <= start:
        return None
    limit = heartbeat_limit()
    since = last_received_before(session, device.id, start)
    heard = device.created_at if since is None else max(since, device.created_at)
    received = session.scalars(
        select(RawEvent.received_at)
        .where(
            RawEvent.device_id == device.id,
            RawEvent.received_at > start,
            RawEvent.received_at <= end,
            *_stored_so_far(session),
        )
        .order_by(RawEvent.received_at)
    )
    ever_heard = since is not None
    for at in received:
        if at - heard > limit:
            return Silence(device.id, heard, at, ongoing=False)
        heard, ever_heard = at, True
    if end - heard > limit or not ever_heard:
        return Silence(device.id, heard, end, ongoing=True)
    return None


def silent_at(session: Session, device: Device, at: datetime) -> bool:
    """Whether ``device`` was stale at server time ``at`` (a decision's moment)."""
    if device.decommissioned_at is not None and device.decommissioned_at <= at:
        return False
    return silent(last_received_before(session, device.id, at), at)


def stale_devices(session: Session, now: datetime) -> list[Device]:
    """Every device stale at server time ``now`` (by :func:`is_stale`), in id order: the list a
    screen shows (it may leave out kinds that do not serve a section)."""
    devices = session.scalars(select(Device).order_by(Device.id))
    return [device for device in devices if is_stale(device, now)]
