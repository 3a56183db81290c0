"""Whether each end's devices were alive while the train passed them (clearance.md,
"Device health" and rule 3).

Staleness judged at one instant — when the server received the arrival — misses a device
that was silent the whole time the train went past it and sent a heartbeat just before a late
``train_arrived``: alive at that instant, its missing evidence looked like nothing to doubt,
and the section was freed (an independent trial, F4). So a device at the arrival end that
owes evidence is judged over the **passage window**: from the departure up to the arrival's
moment, but reaching back no further than :attr:`PassageTimes.believed_lateness` before the
arrival (a train that left days ago must not make every short outage since count). A device
silent past its heartbeat deadline at any point of that window is a doubt, with the gap in
the reason. The departure end's devices are judged the same way over the
``believed_lateness`` before the departure, while the train drew up to them and left.
Everything is read from the raw events' receive times: replay decides the same.
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime, timedelta

from sqlalchemy.orm import Session

from core.models import Section
from ingest.liveness import silent_during
from service.clearance.rules import PassageSilence
from service.setup.service import section_devices


@dataclass(frozen=True)
class PassageTimes:
    """How far the passage window reaches.

    Attributes
    ----------
    believed_lateness
        How long before the arrival's moment the train may have been passing the arrival
        end's devices (an arrival reported late by the interlocking, a train standing at the
        home signal). The window starts at the departure, or this long before the arrival
        when the departure is older.
    """

    believed_lateness: timedelta = timedelta(minutes=10)


PASSAGE = PassageTimes()


def passage_window(
    departure: datetime, arrival: datetime, times: PassageTimes = PASSAGE
) -> tuple[datetime, datetime]:
    """The server times over which the arrival end's devices must have been alive."""
    return max(departure, arrival - times.believed_lateness), arrival


def departure_window(
    departure: datetime, times: PassageTimes = PASSAGE
) -> tuple[datetime, datetime]:
    """The server times over which the departure end's devices must have been alive: the
    train drew up to them and passed them before the departure was reported, up to
    ``believed_lateness`` before it."""
    return departure - times.believed_lateness, departure


def passage_silences(
    session: Session,
    section: Section,
    station: str,
    window: tuple[datetime, datetime],
    known: set[str],
    kinds: tuple[str, ...],
) -> list[PassageSilence]:
    """``station``'s devices of ``kinds`` serving ``section`` that owe evidence and were
    silent past their heartbeat deadline at some point of ``window``, with the gap, in id
    order.

    ``known``: the devices left out — those that reported for the run (they count with what
    they reported, ``evidence.owing_devices``) and those already stale at the side's moment
    (a doubt of their own)."""
    found = []
    for device in section_devices(session, section, station):
        if device.kind not in kinds or device.id in known:
            continue
        gap = silent_during(session, device, *window)
        if gap is not None:
            found.append(PassageSilence(device.id, *gap))
    return sorted(found, key=lambda s: s.device)
