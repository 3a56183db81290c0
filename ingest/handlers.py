"""Routing of stored raw events to the features that derive state from them.

Ingest knows the features only through a handler table: which handlers derive state from
which event model. The application builds that table explicitly (``service/features.py``) and
installs it once at start-up (`install`); ingestion runs the handlers after the raw event row
is stored, and ``depot replay`` runs them again to rebuild derived tables.

A derivation that fails keeps the raw event (``ingest.store.run_derivation``), but the service
has then lost evidence about the section the event names. The installed *failure handler*
(:func:`derivation_failed`) is told of it, so that the section is put to a person rather than
left looking clear; it runs in a savepoint of its own and its own failure is only logged.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from sqlalchemy.exc import InterfaceError, OperationalError, PendingRollbackError
from sqlalchemy.orm import Session

from core.errors import DepotError
from core.models import Device
from ingest.liveness import heard_up_to, restore_pending, seen, snapshot_pending
from ingest.models import RawEvent, StoredRaw
from ingest.schemas import ALL_EVENT_MODELS, EventBase, kind_of, section_of


@dataclass(frozen=True)
class Derivation:
    """What a handler gets: the stored row, its validated event model, and the sending device."""

    session: Session
    raw: RawEvent | StoredRaw  # the ORM row on replay, its columns when just stored
    event: Any
    device: Device
    replaying: bool = False


Handler = Callable[[Derivation], dict[str, Any] | None]
HandlerTable = Mapping[type[EventBase], Sequence[Handler]]
# A feature's checks of an event against stored state (e.g. registered parameters), run
# before anything is stored: they raise core.errors.Unprocessable (422) with the reason.
Validator = Callable[[Session, Any], None]
ValidatorTable = Mapping[type[EventBase], Sequence[Validator]]
# What the handlers of a kind will answer, foreseen from stored state before the raw event is
# stored (None: not foreseeable, e.g. a run that has arrived is decided again). Stored with the
# raw row in its insert, it saves the answer's second write (an UPDATE per event); it may only
# save work, never change what is derived or answered: the handlers still run, and what they
# answer replaces the foreseen answer when the two differ (an earlier event of the same group
# opened a run, say). Called with the device and the validated event, under the transaction.
Foresight = Callable[[Session, Device, Any], dict[str, Any] | None]
ForesightTable = Mapping[type[EventBase], Foresight]
# The features' section lock (one writer decides a section at a time). A group that foresees
# answers takes its sections' locks, in its lock order, before its rows are stored, so that a
# foresight reads the runs as the derivations will; the derivations then find them held.
SectionLock = Callable[[Session, str], object]
# Told of an event naming a section whose derivation failed (the savepoint rolled back; the raw
# event is kept with the error text given): what it reports joins the device's answer.
FailureHandler = Callable[[Derivation, str], dict[str, Any] | None]
log = logging.getLogger("depot.ingest")
# The installed table, indexed by kind (filled by `install`; empty means liveness only).
HANDLERS: dict[str, tuple[Handler, ...]] = {}
VALIDATORS: dict[str, tuple[Validator, ...]] = {}
FORESIGHTS: dict[str, Foresight] = {}
SECTION_LOCK: list[SectionLock] = []
FAILURE_HANDLERS: list[FailureHandler] = []


def check_derivable(session: Session, event: Any) -> None:
    """Run the features' validators of the event's kind (raise 422 before it is stored)."""
    for validate in VALIDATORS.get(event.kind, ()):
        validate(session, event)


def install(
    table: HandlerTable,
    validators: ValidatorTable | None = None,
    foresights: ForesightTable | None = None,
    section_lock: SectionLock | None = None,
    on_failure: FailureHandler | None = None,
) -> None:
    """Install the application's handler table; every event model must have an entry.

    An entry may be empty (the event only proves the device alive). Raises ValueError when a
    kind is missing or unknown, so a new event kind cannot be accepted and then ignored.
    ``on_failure``: the failure handler of events naming a section (:func:`derivation_failed`).
    """
    missing = [kind_of(m) for m in ALL_EVENT_MODELS if m not in table]
    unknown = [model.__name__ for model in table if model not in ALL_EVENT_MODELS]
    if missing or unknown:
        raise ValueError(f"handler table: missing kinds {missing}, unknown models {unknown}")
    HANDLERS.clear()
    HANDLERS.update({kind_of(model): tuple(handlers) for model, handlers in table.items()})
    VALIDATORS.clear()
    VALIDATORS.update({kind_of(model): tuple(v) for model, v in (validators or {}).items()})
    FORESIGHTS.clear()
    FORESIGHTS.update({kind_of(model): f for model, f in (foresights or {}).items()})
    if FORESIGHTS and section_lock is None:
        raise ValueError("foresights need the section lock their derivations take")
    SECTION_LOCK[:] = [] if section_lock is None else [section_lock]
    FAILURE_HANDLERS[:] = [] if on_failure is None else [on_failure]


def can_foresee(kind: str) -> bool:
    """Whether answers to events of ``kind`` may be foreseen (:func:`foreseen_answer`)."""
    return kind in FORESIGHTS


def lock_section(session: Session, section: str) -> None:
    """Take the features' lock of ``section`` (nothing when none is installed)."""
    for lock in SECTION_LOCK:
        lock(session, section)


def foreseen_answer(session: Session, device: Device, event: Any) -> dict[str, Any] | None:
    """The answer the handlers of the event's kind will give (``{"event_id", "status":
    "created", ...}``), when its foresight can tell; None otherwise, or when the foresight
    is refused (the handlers then meet the same refusal, as without a foresight)."""
    foresee = FORESIGHTS.get(event.kind)
    if foresee is None:
        return None
    try:
        answer = foresee(session, device, event)
    except DepotError:
        return None
    if answer is None:
        return None
    return {"event_id": event.event_id, "status": "created", **answer}


# Work a feature can do on an event before anything is stored: in a worker thread, outside the
# database transaction and its locks (detection on an uploaded image, which takes a tenth of a
# second of CPU). Its result may only save the handler work, never change what the handler
# derives: replay runs the handlers without it and must reach the same state.
Preparer = Callable[[Device, Any], None]
PREPARERS: dict[str, Preparer] = {}


def install_preparer(kind: str, preparer: Preparer) -> None:
    """Register the preparer of events of ``kind`` (one per kind; the last one wins)."""
    PREPARERS[kind] = preparer


def prepare(device: Device, event: Any) -> None:
    """Run the preparer of the event's kind, if any (call it off the event loop). A preparer
    that fails changes nothing: the handler does the work itself (and a failure there is the
    stored event's ``derive_error``, as without a preparer)."""
    preparer = PREPARERS.get(event.kind)
    if preparer is None:
        return
    try:
        preparer(device, event)
    except Exception:
        log.exception(
            "preparing %s of %s failed; the derivation does the work", event.kind, device.id
        )


def has_handlers(kind: str) -> bool:
    """Whether any feature derives state from events of ``kind`` (else: liveness only)."""
    return bool(HANDLERS.get(kind))


def derive(derivation: Derivation) -> dict[str, Any]:
    """Run every handler of the event's kind; merge what they report for the client."""
    result: dict[str, Any] = {}
    # A decision reads liveness from the events stored before this one, live and on replay.
    with heard_up_to(derivation.session, derivation.raw.id):
        for handler in HANDLERS.get(derivation.raw.kind, ()):
            result.update(handler(derivation) or {})
    # Liveness counts from when the server received the event, not the device's clock; it has
    # a granularity step: a device sending many events a second need not rewrite its row for
    # each one (decisions read staleness from the raw events' receive times). After the
    # handlers: the device's row is locked after the section a handler locks (lock order; see
    # ``liveness.touched_at_end``), and a handler that fails leaves no trace, as before.
    seen(
        derivation.session,
        derivation.device,
        derivation.raw.received_at,
        replaying=derivation.replaying,
    )
    return result


def derivation_failed(derivation: Derivation, error: str) -> dict[str, Any]:
    """Tell the failure handler that deriving from an event naming a section failed (call it
    after the derivation's savepoint rolled back); what it reports, or nothing.

    In a savepoint of its own: should the handler fail too, that is logged and undone, and the
    raw event and its acknowledgement stay (a failing database still propagates: then nothing
    is acknowledged and the device retries)."""
    if not FAILURE_HANDLERS or section_of(derivation.event) is None:
        return {}
    session = derivation.session
    pending = snapshot_pending(session)
    try:
        with session.begin_nested():
            return FAILURE_HANDLERS[0](derivation, error) or {}
    except (OperationalError, InterfaceError, PendingRollbackError):
        raise
    except Exception:
        log.exception(
            "the failure handler of %s/%s failed; the raw event is kept",
            derivation.device.id,
            derivation.raw.event_id,
        )
        restore_pending(session, pending)
        return {}
