"""Derivations of the clearance feature: runs, reader passages, axle counts, tail snapshots."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar

from sqlalchemy import select
from sqlalchemy.orm import Session

from core.models import Car, Device
from identification import manchester, time_pulse, wheel_marks
from identification.rules import agreed_number
from ingest.handlers import Derivation
from service.clearance import (
    readings_insert,  # noqa: F401  (its flush hook writes readings)
    service,
)
from service.clearance.attribution import placement_at
from service.clearance.models import AxleReading, CarPassage, EotReport, WheelMarking

Row = TypeVar("Row")


def evidence_row(model: Callable[..., Row], d: Derivation, **fields: Any) -> Row:
    """A piece of evidence from the event: the columns every evidence table shares
    (``EvidenceColumns``: raw id, device, its station, the event's section and device time)
    plus the model's own ``fields``."""
    return model(
        id=d.raw.id,
        device_id=d.device.id,
        station=d.device.station,
        section=d.event.section,
        occurred_at=d.event.occurred_at,
        **fields,
    )


def attach_evidence(d: Derivation, row: Any) -> dict[str, Any]:
    """Store the row, attached to the run holding its section at its device time."""
    return service.attach(
        d.session, row, row.section, row.station, row.occurred_at, received=d.raw.received_at
    )


def train_departed(d: Derivation) -> dict[str, Any]:
    return service.open_run(
        d.session,
        d.raw.id,
        d.event.section,
        d.device.station,
        d.event.train,
        d.event.occurred_at,
        eot_unit=d.event.eot_unit,
        received=d.raw.received_at,
    )


def train_arrived(d: Derivation) -> dict[str, Any]:
    return service.close_run(
        d.session,
        d.event.section,
        d.device.station,
        d.event.train,
        d.event.occurred_at,
        received=d.raw.received_at,
        arrival_id=d.raw.id,
    )


def axle_count(d: Derivation) -> dict[str, Any]:
    return attach_evidence(d, evidence_row(AxleReading, d, axles=d.event.axles))


def axle_count_foreseen(session: Session, device: Device, event: Any) -> dict[str, Any] | None:
    """What :func:`axle_count` will answer, as the section's runs stand (under the section's
    lock, which the group took): the run the count is attached to and its side, or none."""
    placement = placement_at(session, event.section, event.occurred_at, device.station)
    return service.attached_answer(event.section, placement.owner, device.station)


def eot_status(d: Derivation) -> dict[str, Any]:
    e = d.event
    row = evidence_row(
        EotReport,
        d,
        unit_address=e.unit_address,
        pressure_psig=e.pressure_psig,
        motion=e.motion,
        marker_light=e.marker_light,
        battery_charge=e.battery_charge,
        bits=e.bits,
    )
    return attach_evidence(d, row)


def _decode_ir_pulses(event: Any) -> tuple[int | None, dict[str, Any]]:
    result = time_pulse.decode_passage(
        event.reply_times_us,
        query_period_us=event.query_period_us,
        reflection_window_us=event.reflection_window_us,
        query_times_us=event.query_times_us,
    )
    return result.car_number, {"reads": list(result.reads), "reason": result.reason}


def _decode_manchester(event: Any) -> tuple[int | None, dict[str, Any]]:
    result = manchester.decode_passage(event.samples, samples_per_bit=event.samples_per_bit)
    detail = {"frames_ok": result.frames_ok, "frames_bad": result.frames_bad}
    return result.car_number, {**detail, "reason": result.reason}


def _decode_wheel_marks(event: Any) -> tuple[int | None, dict[str, Any]]:
    result = wheel_marks.decode_passage(event.baseline, event.axles, direction=event.direction)
    detail = {
        "reason": result.reason,
        "readable_axles": result.readable_axles,
        "margin": result.margin,
    }
    return result.code, detail


def _decode_ir_id(event: Any) -> tuple[int | None, dict[str, Any]]:
    # The same agreeing-reads rule as ir_pulses (identification.rules): one read names no car.
    number, reason = agreed_number(event.reads)
    return number, {"reads": len(event.reads), "reason": reason}


# Each reader event decodes to a car number, or None when it cannot be trusted (and why).
DECODERS = {
    "ir_id": _decode_ir_id,
    "ir_pulses": _decode_ir_pulses,
    "ir_manchester": _decode_manchester,
    "wheel_marks": _decode_wheel_marks,
}


def car_passage(d: Derivation) -> dict[str, Any]:
    number, detail = DECODERS[d.event.kind](d.event)
    column = Car.wheel_code if d.event.kind == "wheel_marks" else Car.ir_number
    car_id = None if number is None else d.session.scalar(select(Car.id).where(column == number))
    row = evidence_row(
        CarPassage, d, kind=d.event.kind, number=number, car_id=car_id, detail=detail
    )
    reason = detail["reason"]
    return {"car_number": number, "car": car_id, "reason": reason, **attach_evidence(d, row)}


def wheel_marks_written(d: Derivation) -> dict[str, Any]:
    car = d.session.get(Car, d.event.car)
    result = wheel_marks.simulate_marking(d.event.detections, axles=car.axles if car else 4)
    faults = list(result.faults) + ([] if car else [f"car {d.event.car} is not registered"])
    d.session.add(
        WheelMarking(
            id=d.raw.id,
            device_id=d.device.id,
            car_id=d.event.car,
            code=d.event.code,
            occurred_at=d.event.occurred_at,
            state=result.state,
            written=list(result.written),
            faults=faults,
        )
    )
    return {"state": result.state, "written": list(result.written), "faults": faults}
