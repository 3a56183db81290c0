"""The handler table: which feature derives state from which device event.

This is the one place where ingest meets the features (cosmicpython's explicit handler
table). A new event kind is a model in ``ingest/schemas.py`` (with its ``senders``) and a
line here; `install` refuses to start when a kind has no entry.
"""

from __future__ import annotations

from ingest import handlers as ingest_handlers
from ingest import schemas as ev
from ingest.handlers import ForesightTable, HandlerTable, ValidatorTable
from service.clearance import faults, tail
from service.clearance import handlers as clearance
from service.clearance.locks import lock_section
from service.fleet import handlers as fleet
from service.setup import service as setup
from service.trains import handlers as trains

HANDLER_TABLE: HandlerTable = {
    ev.TrainDeparted: (clearance.train_departed,),
    ev.TrainArrived: (clearance.train_arrived,),
    ev.AxleCount: (clearance.axle_count,),
    ev.IrId: (clearance.car_passage,),
    ev.IrPulses: (clearance.car_passage,),
    ev.IrManchester: (clearance.car_passage,),
    ev.WheelMarks: (clearance.car_passage,),
    ev.WheelMarksWritten: (clearance.wheel_marks_written,),
    ev.TailSnapshot: (tail.tail_snapshot,),
    ev.Measurement: (fleet.measurement,),
    ev.MotionSample: (trains.motion_sample,),
    ev.EotStatus: (clearance.eot_status,),
    ev.Heartbeat: (),  # liveness only
}


# Checks against stored state that refuse an event (422) before anything of it is stored.
VALIDATOR_TABLE: ValidatorTable = {
    ev.Measurement: (fleet.measurement_values,),
}


# Answers known before the event is stored (stored with it: no second write). Only where the
# answer follows from stored state alone; a wrong foresight costs the write it would save.
FORESIGHT_TABLE: ForesightTable = {
    ev.AxleCount: clearance.axle_count_foreseen,
}


def install() -> None:
    """Install the tables into ingest (idempotent); called by the app factory and the CLI."""
    # An event naming a section whose derivation failed puts the section to a person.
    ingest_handlers.install(
        HANDLER_TABLE,
        VALIDATOR_TABLE,
        FORESIGHT_TABLE,
        section_lock=lock_section,
        on_failure=faults.derivation_failed,
    )
    setup.CAR_REGISTERED[:] = [fleet.derive_waiting]
