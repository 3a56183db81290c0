"""An event about a section whose derivation failed: the section is put to a person.

Safety stance: when evidence is missing the answer is "a person must look", never "clear". A
derivation that fails (an exception in a feature's handler) keeps the raw event and answers
the device 201 with ``derive_error`` (``ingest.store.run_derivation``), but depot has then lost
what the event said about a train in its section: a departure, an axle count, a tail photo.
This module is ingest's failure handler (``ingest.handlers.derivation_failed``, installed by
``service.features``): it records a *fault run* and puts the section in ``review``.

A fault run is no train. Its id is the failed event's raw id (no run of that id exists: the
derivation that would have made one rolled back), its status :data:`occupancy.FAULT`, its
verdict ``undetermined`` and its ``conflict`` the words a dispatcher reads; it has no arrival,
so no evidence is ever attached to it and no run's time windows see it. A dispatcher decides it
like any run (``POST /runs/{id}/decision``: ``clear``, ``keep_blocked``, ``sweep``), audited.

Where it goes: in a ``free`` section it is the current run at once (``review``). In a section
that holds a run, the fault waits behind it like a conflict (``occupancy.next_waiting``): a
section that still waited for evidence (``occupied``, ``awaiting_confirmation``) goes to
``review`` now, and whatever frees the section later (a complete arrival, a dispatcher's clear)
hands it to the fault run instead (``service.promote_conflict``), in ``review``. A section
already in ``alarm``, ``blocked`` or awaiting a sweep stays so (nothing weaker is shown).

Two failed events of one section are two fault runs, each decided by itself, one after the
other (one queue item per section, as for every run): the section is free again only when a
dispatcher has decided every one. A retry of the event is a duplicate and derives nothing, so
it makes no second fault run; replay, which derives every raw event again, makes the same fault
runs (same ids) when the derivations fail again, and re-applies the dispatchers' decisions.
"""

from __future__ import annotations

from typing import Any

from core.models import Section
from core.schemas import format_instant
from ingest.handlers import Derivation
from ingest.schemas import section_of
from service.clearance.doubts import not_ahead
from service.clearance.locks import lock_section
from service.clearance.models import Run
from service.clearance.occupancy import FAULT
from service.clearance.service import set_state

# A fault run's train, when the event named none (all but departures and arrivals).
UNKNOWN_TRAIN = "unknown"
# Sections that waited for evidence: a fault makes them ``review`` at once. Others are already
# a person's (alarm, blocked, review) or closed for a sweep, and stay as they are.
WAITING_STATES = ("free", "occupied", "awaiting_confirmation")


def words(d: Derivation, section: str, error: str) -> str:
    """What the dispatcher reads: which event of which device could not be processed, why."""
    event = d.event
    return (
        f"an event from device {d.device.id} ({event.kind}, event_id {event.event_id}, dated"
        f" {format_instant(event.occurred_at)}) for section {section} could"
        f" not be processed: {error}; what it says about a train in the section is unknown,"
        " a person must look"
    )


def _ends(section: Section, station: str) -> tuple[str, str]:
    """(from, to) seen from the sending device's station (either end of the section)."""
    if station == section.to_station:
        return section.to_station, section.from_station
    return section.from_station, section.to_station


def fault_run(d: Derivation, section: Section, error: str) -> Run:
    """The fault run of a failed derivation (not yet in the session)."""
    text = words(d, section.id, error)
    origin, destination = _ends(section, d.device.station)
    train = getattr(d.event, "train", None) or UNKNOWN_TRAIN
    return Run(
        id=d.raw.id,
        section=section.id,
        train=train,
        from_station=origin,
        to_station=destination,
        departed_at=d.event.occurred_at,  # the event's time: orders it among waiting runs
        arrived_at=None,  # never: a fault run is in no run's time window
        departure_received_at=d.raw.received_at,
        status=FAULT,
        verdict="undetermined",
        decided_at=d.event.occurred_at,
        reasons=[text],
        evidence={
            "fault": {
                "device": d.device.id,
                "kind": d.event.kind,
                "event_id": d.event.event_id,
                "derive_error": error,
            }
        },
        sweep=False,
        conflict=text,
    )


def derivation_failed(d: Derivation, error: str) -> dict[str, Any] | None:
    """ingest's failure handler: record the fault run, put the section to a person."""
    section_id = section_of(d.event)
    if section_id is None:
        return None
    section = lock_section(d.session, section_id)
    if d.session.get(Run, d.raw.id) is not None:
        return None  # already recorded (the same raw event derived twice in one transaction)
    run = fault_run(d, section, error)
    d.session.add(run)
    at = not_ahead(d.event.occurred_at, d.raw.received_at)
    if section.state == "free":
        section.current_run_id = run.id
    if section.state in WAITING_STATES:
        set_state(section, "review", at)
    d.session.flush()
    return {"fault_run": run.id, "section_state": section.state}
