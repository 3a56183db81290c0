"""The decision rules of ``clearance.md``, as a pure function so they can be reviewed and tested.

Nothing here touches the database: the service gathers a :class:`RunEvidence` and asks
:func:`decide`, which returns the verdict and the reasons in a dispatcher's words.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

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
class RunEvidence:
    arrival_tail: TailEvidence | None = None
    departure_tail: TailEvidence | None = None
    consist: ConsistEvidence | None = None
    departure_axles: int | None = None
    arrival_axles: int | None = None
    stale_devices: tuple[str, ...] = field(default_factory=tuple)


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
    return found


def _doubts(evidence: RunEvidence) -> list[str]:
    """What keeps rule 2 from proving completeness (each is a reason for a person to look)."""
    doubts: list[str] = []
    arrival = evidence.arrival_tail
    if arrival is None:
        doubts.append("no arrival image of the last car")
    elif arrival.verdict == "uncertain":
        doubts.append(
            f"the tail disc on the arrival image is uncertain (score {arrival.score:.2f})"
        )
    elif arrival.verdict == "absent":
        doubts.append(
            f"no tail disc found, but with low confidence"
            f" ({arrival.score:.2f} ≤ {arrival.absent_confidence:.2f})"
        )
    if evidence.consist is not None and evidence.consist.status == "unknown":
        doubts.append(evidence.consist.reason)
    d_axles, a_axles = evidence.departure_axles, evidence.arrival_axles
    if d_axles is not None and a_axles is not None and a_axles > d_axles:
        doubts.append(f"{a_axles} axles arrived but only {d_axles} departed: the counts disagree")
    for device in evidence.stale_devices:
        doubts.append(
            f"device {device} is silent past its heartbeat deadline; its evidence is missing"
        )
    return doubts


def _agreements(evidence: RunEvidence) -> list[str]:
    agreed = []
    if evidence.arrival_tail is not None:
        agreed.append(f"tail disc present on arrival (score {evidence.arrival_tail.score:.2f})")
    if evidence.consist is not None and evidence.consist.status == "identical":
        agreed.append(evidence.consist.reason)
    if evidence.departure_axles is not None and evidence.departure_axles == evidence.arrival_axles:
        agreed.append(f"axle counts agree ({evidence.arrival_axles})")
    return agreed


def decide(evidence: RunEvidence) -> Decision:
    """Apply the fixed rules: incomplete if anything proves loss; complete only if the arrival
    tail disc is present and every item present agrees; otherwise undetermined.

    Parameters
    ----------
    evidence : RunEvidence
        What the run has, each item ``None`` when missing (stale devices' evidence is left out).
    """
    losses = _losses(evidence)
    if losses:
        return Decision("incomplete", tuple(losses))
    doubts = _doubts(evidence)
    if doubts:
        return Decision("undetermined", tuple(doubts))
    return Decision("complete", tuple(_agreements(evidence)))


def section_state(verdict: Verdict, mode: str) -> str:
    return SECTION_STATE[(verdict, mode)]
