"""Liveness over the passage: was each device that sent nothing for a train heard while the
train passed it?

A device's silence explains only evidence that did not come (clearance.md, rule 3), and it
must be judged over the time the train may have passed the device, not at one instant: a
reader that went quiet while the train passed and spoke again before the arrival was
reported is as blind as one silent at the arrival. The server does not know when the train
passed an end. It knows when it received the departure and the arrival, which a link down
makes late, and the times their devices gave them, which a wrong clock makes false; each is
a credible instant of the passing, and every one is judged (more doubts, never fewer):

* the departure end: from :attr:`PassageTimes.believed_lateness` before each instant of the
  departure to :attr:`PassageTimes.after_departure` after it, while its devices may still
  report the train — never past the arrival's receipt (:func:`departure_windows`);
* the arrival end: the ``believed_lateness`` up to each instant of the arrival, but not
  before the train could have left (:func:`arrival_windows`).

A device that is alive through the windows but reported nothing for the train is named too
(an arrival-end reader or counter: ``unheard``), without changing the verdict: the rules
already say what its missing evidence leaves unproven.
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime, timedelta

from sqlalchemy.orm import Session

from core.models import Section
from ingest.liveness import Silence, silent_during
from service.clearance.attribution import WINDOWS
from service.clearance.models import Run
from service.setup.service import section_devices


@dataclass(frozen=True)
class PassageTimes:
    """How the server bounds when a train passed an end of its section.

    Attributes
    ----------
    believed_lateness
        How long after a train passed an end its report may reach the server, or its device
        date it (a link down, a device's queue): each end's window reaches back this far from
        each credible instant of the report. Longer judges a device over more of its past
        (more doubts, never fewer); shorter could miss a silence while the train passed.
    after_departure
        How long after the departure the departure end's devices still see the train and
        may report it: the attribution's bound (``AttachmentWindows.after_departure``), so
        that a device silent while its evidence could still belong to the run is judged.
    """

    believed_lateness: timedelta = timedelta(minutes=10)
    after_departure: timedelta = WINDOWS.after_departure


PASSAGE = PassageTimes()
# Kinds whose silence at an end leaves a run's evidence missing, and those named when alive
# but silent for the train (a camera's missing photo is a doubt of its own).
EVIDENCE_DEVICE_KINDS = ("camera", "wheel_mark_reader", "ir_reader", "axle_counter")
EOT_KINDS = ("eot_receiver",)
UNHEARD_KINDS = ("wheel_mark_reader", "ir_reader", "axle_counter")


@dataclass(frozen=True)
class Window:
    """Server times (UTC) between which the train may have passed one end."""

    start: datetime
    end: datetime


@dataclass(frozen=True)
class Report:
    """When a departure or an arrival was received by the server, and the time its device
    gave it (a clock can be wrong, a link late: both are credible instants of the passing)."""

    received: datetime
    dated: datetime


def departure_windows(
    departure: Report, arrival_received: datetime, *, times: PassageTimes = PASSAGE
) -> list[Window]:
    """The departure end's windows: around each credible instant of the departure (its
    receipt, its device time; neither after the arrival's receipt, by when the train had left),
    from ``times.believed_lateness`` before to ``times.after_departure`` after it, never past
    the arrival's receipt."""
    instants = sorted({min(departure.received, arrival_received),
                       min(departure.dated, arrival_received)})  # fmt: skip
    return [
        Window(t - times.believed_lateness, min(t + times.after_departure, arrival_received))
        for t in instants
    ]


def arrival_windows(
    departure: Report, arrival: Report, *, times: PassageTimes = PASSAGE
) -> list[Window]:
    """The arrival end's windows: up to each credible instant of the arrival (its receipt,
    its device time if earlier), from ``times.believed_lateness`` before it but not before
    the train could have left (the departure's earliest instant)."""
    left = min(departure.received, departure.dated, arrival.received)
    windows = []
    for t in sorted({arrival.received, min(arrival.dated, arrival.received)}):
        start = max(left, t - times.believed_lateness)
        windows.append(Window(start if start < t else t - times.believed_lateness, t))
    return windows


@dataclass(frozen=True)
class Liveness:
    """What the devices of both ends were, for one run: ``silences`` of those whose evidence
    is missing (each with its times), and ``unheard``: arrival-end devices alive throughout
    that reported nothing for the train."""

    silences: tuple[Silence, ...]
    unheard: tuple[str, ...]


def passage_silences(
    session: Session,
    section: Section,
    station: str,
    windows: list[Window],
    contributed: set[str],
    kinds: tuple[str, ...] = EVIDENCE_DEVICE_KINDS,
) -> tuple[list[Silence], list[str]]:
    """The devices of ``kinds`` at ``station`` that sent nothing for the run: those silent at
    some time in one of ``windows`` (their evidence is missing; the first silence found), and
    those alive throughout."""
    silences: list[Silence] = []
    alive: list[str] = []
    for device in section_devices(session, section, station):
        if device.kind not in kinds or device.id in contributed:
            continue
        found = (silent_during(session, device, w.start, w.end) for w in windows)
        silence = next((x for x in found if x is not None), None)
        if silence is not None:
            silences.append(silence)
        elif device.kind in UNHEARD_KINDS and device.decommissioned_at is None:
            alive.append(device.id)
    return silences, alive


def run_windows(run: Run) -> tuple[list[Window], list[Window]]:
    """The departure end's and the arrival end's windows of an arrived run. Device times
    stand in for receipts of runs stored before those were recorded."""
    departure = Report(run.departure_received_at or run.departed_at, run.departed_at)
    dated = run.arrived_at or departure.received
    arrival = Report(run.arrival_received_at or dated, dated)
    return departure_windows(departure, arrival.received), arrival_windows(departure, arrival)


def liveness(session: Session, run: Run, section: Section, contributed: set[str]) -> Liveness:
    """Judge the devices of both ends of ``run`` that sent it nothing (:class:`Liveness`); the
    EOT receiver only for a train that carries an EOT unit."""
    at_departure, at_arrival = run_windows(run)
    found, unheard = passage_silences(session, section, run.to_station, at_arrival, contributed)
    found += passage_silences(session, section, run.from_station, at_departure, contributed)[0]
    if run.eot_unit is not None:
        found += passage_silences(
            session, section, run.to_station, at_arrival, contributed, EOT_KINDS
        )[0]
    return Liveness(tuple(sorted(found, key=lambda s: s.device)), tuple(unheard))
