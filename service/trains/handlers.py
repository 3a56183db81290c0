"""Derivation of ``motion_sample`` events: the train's filter advances by one sample."""

from __future__ import annotations

from typing import Any

from ingest.handlers import Derivation
from ingest.schemas import MotionSample
from motion.samples import StaleSampleError
from service.trains import service


def sample_of(event: MotionSample) -> dict[str, Any]:
    """The filter's input from a validated event: the sample's own fields only."""
    return event.model_dump(exclude_none=True, exclude={"event_id", "occurred_at", "kind"})


def motion_sample(d: Derivation) -> dict[str, Any]:
    try:
        state = service.feed(
            d.session, d.event.train, sample_of(d.event), d.event.occurred_at, d.device.id
        )
    except StaleSampleError as exc:
        # Later than the late-sample bound, or one of an unconfirmed clock jump or restart:
        # the event is kept and the device told why, not applied.
        # (Any other ValueError would be a sample the schema let through against the rules
        # in motion.samples: it is a fault, recorded as a derive_error, not a warning.)
        return {"position": None, "warning": str(exc)}
    keys = ("position_m", "speed_mps", "sigma_position_m", "section", "reader_on")
    return {"position": {k: state.get(k) for k in keys}}
