"""Derivation of ``motion_sample`` events: the train's filter advances by one sample."""

from __future__ import annotations

from typing import Any

from ingest.handlers import Derivation
from service.trains import service


def motion_sample(d: Derivation) -> dict[str, Any]:
    sample = d.event.model_dump(exclude_none=True, exclude={"event_id", "occurred_at", "kind"})
    try:
        state = service.feed(d.session, d.event.train, sample, d.event.occurred_at)
    except ValueError as exc:  # e.g. a sample older than the filter's buffer: kept, not applied
        return {"position": None, "warning": str(exc)}
    keys = ("position_m", "speed_mps", "sigma_position_m", "section", "reader_on")
    return {"position": {k: state.get(k) for k in keys}}
