"""Liveness over the passage: was each device that sent nothing for a train heard while the
train passed it?

A device's silence explains only evidence that did not come (clearance.md, rule 3), and it
must be judged over the time the train may have passed the device, not at one instant: a
reader that went quiet while the train passed and spoke again before the arrival was
reported is as blind as one silent at the arrival. The server does not know when the train
passed an end, only when it received the departure and the arrival; a report may reach it
late, by up to :attr:`PassageTimes.believed_lateness`. So each end's window runs from the
earliest time the train may have passed to when the server received its report:

* the arrival end: from the departure (at most ``believed_lateness`` before the arrival was
  received) to the arrival's receipt (:func:`passage_window`);
* the departure end: the ``believed_lateness`` before the departure's receipt, or the
  arrival's if that came first (:func:`departure_window`).

A device that is alive through the window but reported nothing for the train is named too
(an arrival-end reader or counter: ``unheard``), without changing the verdict: the rules
already say what its missing evidence leaves unproven.
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime, timedelta

from sqlalchemy.orm import Session

from core.models import Section
from ingest.liveness import Silence, silent_during
from service.clearance.models import Run
from service.setup.service import section_devices


@dataclass(frozen=True)
class PassageTimes:
    """How the server bounds when a train passed an end of its section.

    Attributes
    ----------
    believed_lateness
        How long after a train passed an end its departure or arrival may reach the server
        (a link down, a device's queue): the window of each end reaches back this far from
        the report's receipt. Longer judges a device over more of its past (more doubts,
        never fewer); shorter could miss a silence while the train passed.
    """

    believed_lateness: timedelta = timedelta(minutes=10)


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


def passage_window(
    departure: datetime, arrival: datetime, *, times: PassageTimes = PASSAGE
) -> Window:
    """The arrival end's window: from the departure's receipt, but at most
    ``times.believed_lateness`` before the arrival's, to the arrival's receipt. A departure
    received after the arrival (its link was down) says nothing of when the train passed the
    arrival end: then the whole ``believed_lateness`` before the arrival counts."""
    earliest = arrival - times.believed_lateness
    return Window(departure if earliest < departure < arrival else earliest, arrival)


def departure_window(
    departure: datetime, arrival: datetime | None = None, *, times: PassageTimes = PASSAGE
) -> Window:
    """The departure end's window: the ``times.believed_lateness`` before the departure's
    receipt, or before the arrival's when that came first (the train had left by then)."""
    left = departure if arrival is None else min(departure, arrival)
    return Window(left - times.believed_lateness, left)


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
    window: Window,
    contributed: set[str],
    kinds: tuple[str, ...] = EVIDENCE_DEVICE_KINDS,
) -> tuple[list[Silence], list[str]]:
    """The devices of ``kinds`` at ``station`` that sent nothing for the run: those silent at
    some time in ``window`` (their evidence is missing), and those alive throughout."""
    silences: list[Silence] = []
    alive: list[str] = []
    for device in section_devices(session, section, station):
        if device.kind not in kinds or device.id in contributed:
            continue
        silence = silent_during(session, device, window.start, window.end)
        if silence is not None:
            silences.append(silence)
        elif device.kind in UNHEARD_KINDS and device.decommissioned_at is None:
            alive.append(device.id)
    return silences, alive


def run_windows(run: Run) -> tuple[Window, Window]:
    """The departure end's and the arrival end's windows of an arrived run. Device times
    stand in for runs stored before the receive times were recorded."""
    departure = run.departure_received_at or run.departed_at
    arrival = run.arrival_received_at or run.arrived_at or departure
    return departure_window(departure, arrival), passage_window(departure, arrival)


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
