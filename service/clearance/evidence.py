"""Attaching evidence to runs by section, station side and time, and gathering it for a decision."""

from __future__ import annotations

from dataclasses import dataclass
from datetime import timedelta
from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session

from core.models import Car, Device, Section
from core.schemas import format_instant
from identification.consist import compare_consists
from ingest.models import Snapshot
from service.clearance.certainty import judge
from service.clearance.models import AxleReading, CarPassage, EotReport, Run
from service.clearance.passage import liveness
from service.clearance.readers import disagreement_reason, reader_disagreements
from service.clearance.rules import (
    ConsistEvidence,
    EotEvidence,
    EotReading,
    PassageSilence,
    RunEvidence,
    TailEvidence,
    ZeroCount,
    eot_stands_in,
)
from tail_check.profile import CameraProfile

DEFAULT_ABSENT_CONFIDENCE = CameraProfile().absent_confidence
# An EOT report counts for the run between departure and this long after arrival (clearance.md).
EOT_AFTER_ARRIVAL = timedelta(seconds=60)


# Every report counts, not the last one: the verdict that weighs most for safety stands for
# its side (an arrival ``absent`` above a ``present``; a departure ``present``, the reference
# whose absence on arrival proves a loss, above the rest).
TAIL_WEIGHT = {
    "arrival": {"absent": 2, "present": 1, "uncertain": 0},
    "departure": {"present": 2, "absent": 1, "uncertain": 0},
}


def _tail(snapshots: list[Snapshot], side: str) -> TailEvidence | None:
    mine = [s for s in snapshots if s.side == side and s.verdict is not None]
    if not mine:
        return None
    weight = TAIL_WEIGHT[side]
    chosen = max(mine, key=lambda s: (weight[s.verdict or ""], s.score or 0.0, s.occurred_at, s.id))
    threshold = (chosen.detection or {}).get("absent_confidence", DEFAULT_ABSENT_CONFIDENCE)
    return TailEvidence(
        verdict=chosen.verdict,  # type: ignore[arg-type]
        score=float(chosen.score or 0.0),
        snapshot_id=chosen.id,
        absent_confidence=float(threshold),
    )


def contradictions(snapshots: list[Snapshot], readings: list[AxleReading]) -> list[str]:
    """Reports of one side that disagree with each other: a person must look (rule 3) unless
    one of them proves a loss (rule 1, decided before)."""
    found = []
    for side in ("departure", "arrival"):
        seen = sorted(
            (s for s in snapshots if s.side == side and s.verdict in ("present", "absent")),
            key=lambda s: s.id,
        )
        if len({s.verdict for s in seen}) > 1:
            shown = ", ".join(
                f"{s.verdict} (snapshot {s.id}, score {s.score or 0:.2f})" for s in seen
            )
            found.append(f"the {side} images contradict each other: tail disc {shown}")
        counts = sorted({r.axles for r in readings if r.side == side and r.axles > 0})
        if len(counts) > 1:
            found.append(
                f"the {side} axle counts contradict each other:"
                f" {', '.join(str(c) for c in counts)} axles reported"
            )
    return found


def _car_label(passage: CarPassage) -> str | None:
    if passage.car_id is not None:
        return passage.car_id
    return None if passage.number is None else f"#{passage.number}"


def consists(passages: list[CarPassage]) -> dict[str, dict[str, list[str | None]]]:
    """Consists per technology family (``wheel``/``ir``) and side, in passing order."""
    out: dict[str, dict[str, list[str | None]]] = {}
    for passage in sorted(passages, key=lambda p: (p.occurred_at, p.id)):
        family = "wheel" if passage.kind == "wheel_marks" else "ir"
        out.setdefault(family, {}).setdefault(passage.side or "", []).append(_car_label(passage))
    return out


def compare_families(
    families: dict[str, dict[str, list[str | None]]],
) -> tuple[ConsistEvidence | None, dict[str, Any]]:
    """Compare departure and arrival consists of each family; the gravest outcome counts."""
    gravity = {"missing": 2, "unknown": 1, "identical": 0}
    chosen: ConsistEvidence | None = None
    shown: dict[str, Any] = {}
    for family, sides in sorted(families.items()):
        departure, arrival = sides.get("departure"), sides.get("arrival")
        if not departure or not arrival:
            continue
        comparison = compare_consists(departure, arrival)
        shown[family] = {
            "status": comparison.status,
            "reason": comparison.reason,
            "aligned": [list(row) for row in comparison.aligned],
        }
        item = ConsistEvidence(status=comparison.status, reason=comparison.reason)
        if chosen is None or gravity[item.status] > gravity[chosen.status]:
            chosen = item
    disagreements = reader_disagreements(families)
    if not disagreements:
        return chosen, shown
    # A loss is still proven when every technology shows it; else nothing is, either way.
    reason = disagreement_reason(disagreements)
    if not shown or any(c["status"] != "missing" for c in shown.values()):
        chosen = ConsistEvidence(status="unknown", reason=reason)
    for comparison_shown in shown.values():
        if comparison_shown["status"] == "identical":  # not "same cars" beside the other's
            comparison_shown.update(status="unknown", reason=reason)
    return chosen, shown


def _axles(
    session: Session, readings: list[AxleReading], side: str, family_cars: list[str | None] | None
) -> int | None:
    mine = [r.axles for r in readings if r.side == side and r.axles > 0]  # 0 is no count
    if mine:  # every count counts: the pair that would prove a loss (fewest arrived, most left)
        return min(mine) if side == "arrival" else max(mine)
    if not family_cars or any(car is None or car.startswith("#") for car in family_cars):
        return None
    cars = [session.get(Car, car) for car in family_cars]
    return None if any(c is None for c in cars) else sum(c.axles for c in cars if c is not None)


def _eot(
    session: Session, run: Run, unproven: frozenset[int]
) -> tuple[EotEvidence | None, list[EotReport]]:
    """Arrival-side EOT reports from departure to arrival + 60 s, oldest first (but those
    that cannot be placed in the run with certainty)."""
    rows = [
        r
        for r in session.scalars(
            select(EotReport)
            .where(EotReport.run_id == run.id, EotReport.side == "arrival")
            .order_by(EotReport.occurred_at, EotReport.id)
        )
        if r.id not in unproven
        and r.occurred_at >= run.departed_at
        and (run.arrived_at is None or r.occurred_at <= run.arrived_at + EOT_AFTER_ARRIVAL)
    ]
    if run.eot_unit is None and not rows:
        return None, rows
    readings = tuple(EotReading(r.unit_address, r.pressure_psig) for r in rows)
    return EotEvidence(unit=run.eot_unit, reports=readings), rows


def _eot_summary(evidence: RunEvidence, rows: list[EotReport]) -> dict[str, Any] | None:
    if evidence.eot is None:
        return None
    return {
        "unit": evidence.eot.unit,
        "stands_in_for_tail": eot_stands_in(evidence),
        "reports": [
            {
                "id": r.id,
                "device": r.device_id,
                "occurred_at": format_instant(r.occurred_at),
                "unit_address": r.unit_address,
                "pressure_psig": r.pressure_psig,
                "motion": r.motion,
                "marker_light": r.marker_light,
                "own_unit": r.unit_address == evidence.eot.unit,
            }
            for r in rows
        ],
    }


@dataclass(frozen=True)
class Gathered:
    evidence: RunEvidence
    summary: dict[str, Any]


def gather(session: Session, run: Run, section: Section) -> Gathered:
    """Everything attached to the run, and the devices whose evidence is missing because
    they were silent (their items stay ``None``: missing, never assumed)."""
    judged = judge(session, run)
    attached = list(session.scalars(select(Snapshot).where(Snapshot.run_id == run.id)))
    # Evidence that cannot be placed in this run with certainty proves nothing (certainty).
    snapshots = [s for s in attached if s.id not in judged.unproven]
    passages = [
        p
        for p in session.scalars(select(CarPassage).where(CarPassage.run_id == run.id))
        if p.id not in judged.unproven
    ]
    readings = [
        r
        for r in session.scalars(select(AxleReading).where(AxleReading.run_id == run.id))
        if r.id not in judged.unproven
    ]
    eot, eot_rows = _eot(session, run, judged.unproven)
    contributed = (
        {s.device_id for s in snapshots}
        | {p.device_id for p in passages}
        | {r.device_id for r in readings}
        | {e.device_id for e in eot_rows}
    )
    heard = liveness(session, run, section, contributed)
    silences = tuple(PassageSilence(x.device, x.heard, x.until, x.ongoing) for x in heard.silences)
    families = consists(passages)
    consist, shown = compare_families(families)
    best = families.get("wheel") or families.get("ir") or {}
    evidence = RunEvidence(
        arrival_tail=_tail(snapshots, "arrival"),
        departure_tail=_tail(snapshots, "departure"),
        consist=consist,
        departure_axles=_axles(session, readings, "departure", best.get("departure")),
        arrival_axles=_axles(session, readings, "arrival", best.get("arrival")),
        silences=silences,
        zero_counts=tuple(ZeroCount(r.device_id, r.station) for r in readings if r.axles <= 0),
        unheard=heard.unheard,
        eot=eot,
        contradictions=(*judged.doubts, *contradictions(snapshots, readings)),
    )
    summary = {
        "tail": {
            side: None
            if tail is None
            else {
                "verdict": tail.verdict,
                "score": round(tail.score, 3),
                "snapshot_id": tail.snapshot_id,
            }
            for side, tail in (
                ("departure", evidence.departure_tail),
                ("arrival", evidence.arrival_tail),
            )
        },
        "consists": {
            family: {side: cars for side, cars in sides.items()}
            for family, sides in families.items()
        },
        "consist_comparison": shown,
        "axles": {"departure": evidence.departure_axles, "arrival": evidence.arrival_axles},
        "stale_devices": sorted({x.device for x in silences}),
        "silent_while_passing": [
            {
                "device": x.device,
                "heard_at": format_instant(x.heard),
                "silent_until": format_instant(x.until),
                "ongoing": x.ongoing,
            }
            for x in silences
        ],
        "unheard_devices": list(heard.unheard),
        "zero_axle_counts": sorted({z.device for z in evidence.zero_counts}),
        "snapshot_ids": sorted(s.id for s in attached),
        "uncertain_evidence": sorted(judged.unproven),
        "eot": _eot_summary(evidence, eot_rows),
    }
    return Gathered(evidence, summary)


def devices_of(session: Session, ids: list[str]) -> list[Device]:
    return list(session.scalars(select(Device).where(Device.id.in_(ids))))
