"""The decision rules of ``clearance.md``, as a pure function so they can be reviewed and tested.

Nothing here touches the database: the service gathers a :class:`RunEvidence` and asks
:func:`decide`, which returns the verdict and the reasons in a dispatcher's words.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from datetime import datetime
from typing import Literal

from core.schemas import format_instant

Verdict = Literal["complete", "incomplete", "undetermined"]

SECTION_STATE = {
    ("complete", "primary"): "free",
    ("complete", "auxiliary"): "awaiting_confirmation",
    ("undetermined", "primary"): "review",
    ("undetermined", "auxiliary"): "review",
    ("incomplete", "primary"): "alarm",
    ("incomplete", "auxiliary"): "alarm",
}


@dataclass(frozen=True)
class TailEvidence:
    """A tail-disc verdict; ``absent_confidence`` is the camera profile's threshold above which
    an ``absent`` verdict proves loss."""

    verdict: Literal["present", "absent", "uncertain"]
    score: float
    snapshot_id: int | None = None
    absent_confidence: float = 0.8


@dataclass(frozen=True)
class ConsistEvidence:
    """Departure and arrival consists compared: ``identical``, ``missing`` or ``unknown``."""

    status: Literal["identical", "missing", "unknown"]
    reason: str


@dataclass(frozen=True)
class EotThresholds:
    """Brake-pipe pressures at the rear (psig) that the EOT rules read (clearance.md, EOT).

    Attributes
    ----------
    whole_psig
        At or above: the brake pipe reaches the last car at pressure, so the train is whole up
        to the EOT unit; stands in for the arrival tail disc in rule 2.
    vented_psig
        Below: the pipe is vented at the rear, the classic sign of a parted train (rule 1).
    """

    whole_psig: int = 45
    vented_psig: int = 5


EOT = EotThresholds()


@dataclass(frozen=True)
class EotReading:
    """One arrival-side ``eot_status`` report in the run's window, as the rules see it."""

    unit_address: int
    pressure_psig: int


@dataclass(frozen=True)
class EotEvidence:
    """The EOT unit armed on the train (``train_departed.eot_unit``, or None) and the
    arrival-side reports between departure and arrival + 60 s, oldest first."""

    unit: int | None
    reports: tuple[EotReading, ...] = ()


@dataclass(frozen=True)
class PassageSilence:
    """A device that sent nothing for the run and was silent past its heartbeat deadline
    while the train may have passed it: nothing received after ``heard`` until ``until``
    (``ongoing``: still nothing at the end of the window)."""

    device: str
    heard: datetime
    until: datetime
    ongoing: bool = True


@dataclass(frozen=True)
class ZeroCount:
    """An axle count of 0 for a train: a counter that counted nothing, not a count."""

    device: str
    station: str


@dataclass(frozen=True)
class RunEvidence:
    arrival_tail: TailEvidence | None = None
    departure_tail: TailEvidence | None = None
    consist: ConsistEvidence | None = None
    departure_axles: int | None = None
    arrival_axles: int | None = None
    # Devices whose evidence is missing because they were silent while the train passed.
    silences: tuple[PassageSilence, ...] = field(default_factory=tuple)
    eot: EotEvidence | None = None
    # Reports of one side that disagree with each other (in words); never ``complete``.
    contradictions: tuple[str, ...] = field(default_factory=tuple)
    # Axle counts of 0 (left out of the counts compared): each a doubt.
    zero_counts: tuple[ZeroCount, ...] = field(default_factory=tuple)
    # Arrival-end devices alive throughout that reported nothing for the train: named only.
    unheard: tuple[str, ...] = field(default_factory=tuple)


def _eot_last(evidence: RunEvidence) -> EotReading | None:
    """The last report of the train's own EOT unit (reports of other units do not count)."""
    eot = evidence.eot
    if eot is None or eot.unit is None:
        return None
    own = [r for r in eot.reports if r.unit_address == eot.unit]
    return own[-1] if own else None


def eot_stands_in(evidence: RunEvidence) -> bool:
    """Whether the train's own EOT unit proves the last car arrived (≥ 45 psig at the rear)."""
    last = _eot_last(evidence)
    return last is not None and last.pressure_psig >= EOT.whole_psig


def _eot_ignored(evidence: RunEvidence) -> list[str]:
    """Reports from other unit addresses: ignored, each unit once, with the reason."""
    eot = evidence.eot
    if eot is None:
        return []
    others = sorted({r.unit_address for r in eot.reports if r.unit_address != eot.unit})
    if eot.unit is None:
        return [
            f"EOT unit {u} reported, but no EOT unit was armed on this train: ignored"
            for u in others
        ]
    return [
        f"EOT unit {u} is not this train's unit ({eot.unit}): its report is ignored" for u in others
    ]


@dataclass(frozen=True)
class Decision:
    verdict: Verdict
    reasons: tuple[str, ...]


def _losses(evidence: RunEvidence) -> list[str]:
    """Rule 1: every item that proves the train lost cars."""
    found: list[str] = []
    arrival, departure = evidence.arrival_tail, evidence.departure_tail
    if arrival is not None and arrival.verdict == "absent":
        if departure is not None and departure.verdict == "present":
            found.append(
                "the tail disc seen on departure is not on the arriving train"
                f" (arrival score {arrival.score:.2f})"
            )
        elif arrival.score > arrival.absent_confidence:
            found.append(f"no tail disc on the arriving train (confidence {arrival.score:.2f})")
    if evidence.consist is not None and evidence.consist.status == "missing":
        found.append(evidence.consist.reason)
    d_axles, a_axles = evidence.departure_axles, evidence.arrival_axles
    if d_axles is not None and a_axles is not None and a_axles < d_axles:
        found.append(
            f"{a_axles} axles arrived of {d_axles} that departed ({d_axles - a_axles} missing)"
        )
    last = _eot_last(evidence)
    if last is not None and last.pressure_psig < EOT.vented_psig:
        found.append(
            "brake pipe vented at the rear: the train may have parted"
            f" (EOT unit {last.unit_address} reports {last.pressure_psig} psig)"
        )
    return found


def _present(tail: TailEvidence | None) -> bool:
    return tail is not None and tail.verdict == "present"


def _doubts(evidence: RunEvidence) -> list[str]:
    """What keeps rule 2 from proving completeness (each is a reason for a person to look)."""
    doubts: list[str] = []
    arrival = evidence.arrival_tail
    stand_in = eot_stands_in(evidence)
    if arrival is None and not stand_in:
        doubts.append("no arrival image of the last car")
        eot = evidence.eot
        if eot is not None and eot.unit is not None and _eot_last(evidence) is None:
            doubts.append(f"no report from EOT unit {eot.unit} at arrival")
    elif arrival is None:
        pass  # the EOT unit at pressure stands in for the tail disc (rule 2)
    elif arrival.verdict == "uncertain" and not stand_in:
        doubts.append(
            f"the tail disc on the arrival image is uncertain (score {arrival.score:.2f})"
        )
    elif arrival.verdict == "absent":
        doubts.append(
            f"no tail disc found, but with low confidence"
            f" ({arrival.score:.2f} ≤ {arrival.absent_confidence:.2f})"
        )
    departure = evidence.departure_tail
    if departure is not None and departure.verdict == "absent" and _present(arrival):
        # Rule 2: no item may contradict the arrival disc. A train that left without its disc
        # cannot arrive with one: one of the two images is of another train, or is wrong.
        doubts.append(
            f"the departure image shows no tail disc (score {departure.score:.2f}) but the"
            " arrival image shows one: the images contradict each other; a person must look"
        )
    if evidence.consist is not None and evidence.consist.status == "unknown":
        doubts.append(evidence.consist.reason)
    d_axles, a_axles = evidence.departure_axles, evidence.arrival_axles
    if d_axles is not None and a_axles is not None and a_axles > d_axles:
        doubts.append(f"{a_axles} axles arrived but only {d_axles} departed: the counts disagree")
    doubts.extend(evidence.contradictions)
    doubts.extend(silence_words(silence) for silence in evidence.silences)
    for zero in evidence.zero_counts:
        doubts.append(
            f"the axle counter {zero.device} at {zero.station} reported 0 axles for a train:"
            " that is no count; a person must look"
        )
    last = _eot_last(evidence)
    if last is not None and EOT.vented_psig <= last.pressure_psig < EOT.whole_psig:
        doubts.append(
            f"EOT unit {last.unit_address} at the rear reports only {last.pressure_psig} psig"
            f" at arrival ({EOT.whole_psig} psig or more proves the train whole)"
        )
    return doubts


def silence_words(silence: PassageSilence) -> str:
    """A silent device in a dispatcher's words, with the times it was not heard."""
    until = "" if silence.ongoing else f" to {format_instant(silence.until)}"
    return (
        f"device {silence.device} is silent past its heartbeat deadline while the train passed"
        f" (nothing received from {format_instant(silence.heard)}{until}); its evidence is"
        " missing; a person must look"
    )


def _unheard(evidence: RunEvidence) -> list[str]:
    return [
        f"device {device} is alive but reported nothing for this train: the decision does not"
        " rest on it"
        for device in evidence.unheard
    ]


def _agreements(evidence: RunEvidence) -> list[str]:
    agreed = []
    tail = evidence.arrival_tail
    if tail is not None and tail.verdict == "present":
        agreed.append(f"tail disc present on arrival (score {tail.score:.2f})")
    elif tail is not None:
        agreed.append(
            f"the tail disc is {tail.verdict} (score {tail.score:.2f}); the EOT unit stands in"
        )
    last = _eot_last(evidence)
    if last is not None:
        agreed.append(
            f"EOT unit {last.unit_address} at the rear reports {last.pressure_psig} psig at arrival"
        )
    if evidence.consist is not None and evidence.consist.status == "identical":
        agreed.append(evidence.consist.reason)
    if evidence.departure_axles is not None and evidence.departure_axles == evidence.arrival_axles:
        agreed.append(f"axle counts agree ({evidence.arrival_axles})")
    return agreed


def decide(evidence: RunEvidence) -> Decision:
    """Apply the fixed rules: incomplete if anything proves loss; complete only if the arrival
    tail disc is present (or the train's own EOT unit reports ≥ 45 psig at arrival, standing in
    for it) and every item present agrees; otherwise undetermined. Reports of other EOT units
    are ignored, with a reason. A weak ``absent`` tail stays a doubt even with the EOT at
    pressure: an item that is present and does not agree. A device silent while the train
    passed, and an axle count of 0, are doubts; a live device that reported nothing is named
    without changing the verdict.

    Parameters
    ----------
    evidence : RunEvidence
        What the run has, each item ``None`` when missing (silent devices' evidence is left
        out).
    """
    ignored = [*_eot_ignored(evidence), *_unheard(evidence)]
    losses = _losses(evidence)
    if losses:
        return Decision("incomplete", (*losses, *ignored))
    doubts = _doubts(evidence)
    if doubts:
        return Decision("undetermined", (*doubts, *ignored))
    return Decision("complete", (*_agreements(evidence), *ignored))


def section_state(verdict: Verdict, mode: str) -> str:
    return SECTION_STATE[(verdict, mode)]


# A dispatcher may ask for a sweep only where nothing proves the section empty.
SWEEP_FROM = frozenset({"alarm", "review", "blocked"})


def next_state(current: str, verdict: Verdict, mode: str) -> str:
    """Where the section goes after a (re-)decision of the run holding it.

    Proof of loss always raises the alarm (even on a section already freed). Otherwise only the
    states that wait for evidence follow the verdict: an alarm or a dispatcher's block is left
    for a person, and a freed section is not closed again by mere doubt. A sweep run follows
    the same table (clearance.md): ``complete`` frees (or awaits confirmation), ``incomplete``
    raises the alarm, ``undetermined`` asks for review.
    """
    if verdict == "incomplete":
        return current if current == "blocked" else "alarm"
    if current in ("occupied", "review", "awaiting_confirmation"):
        return section_state(verdict, mode)
    return current


def redecided_state(current: str, verdict: Verdict, mode: str, new_concern: bool) -> str:
    """Where the section goes when late evidence decides its current run again, after a
    decision was shown (by the rules or by a dispatcher).

    While the section still waits for evidence (``occupied``, ``review``,
    ``awaiting_confirmation``) it follows the verdict (:func:`next_state`). A settled state —
    freed, cleared, kept blocked, in alarm, awaiting a sweep — changes only for a
    ``new_concern``, a reason the decision shown did not have: a new proof of loss raises the
    alarm, a new doubt on a free section asks for review. Late evidence that agrees with what
    was shown changes nothing: it never re-raises an alarm a dispatcher has cleared.
    """
    if current in ("occupied", "review", "awaiting_confirmation"):
        return next_state(current, verdict, mode)
    if not new_concern:
        return current
    if verdict == "incomplete":
        return next_state(current, verdict, mode)
    return "review" if verdict == "undetermined" and current == "free" else current


def departure_opens_sweep(state: str) -> bool:
    """A train departing into a section awaiting a sweep is the sweep run, not a conflict."""
    return state == "awaiting_sweep"


def sweep_clears_original(sweep_verdict: Verdict | None) -> bool:
    """The original run counts as cleared by the sweep only when the sweep run is complete."""
    return sweep_verdict == "complete"


def describe_sweep(sweep_run: int, original: int, verdict: Verdict) -> str:
    """The words shown for a sweep run's outcome."""
    if verdict == "complete":
        return f"sweep run {sweep_run} arrived complete: run {original}'s section is proved empty"
    if verdict == "incomplete":
        return f"sweep run {sweep_run} arrived incomplete: the section is in alarm again"
    return (
        f"sweep run {sweep_run} is undetermined:"
        f" a person must look before run {original} is cleared"
    )
