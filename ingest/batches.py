"""The one rule that tells a batch from a single event, shared by every transport."""

from __future__ import annotations

from typing import Any

from pydantic import ValidationError

from core.errors import Unprocessable, validation_errors
from ingest.schemas import EventBatch


def batch_events(payload: Any) -> list[dict[str, Any]] | None:
    """The events of a batch payload (``{"events": [...]}``), or None for a single event.

    A payload is a batch when it is an object with ``events`` and no ``kind`` of its own; a
    malformed batch (empty, more than 1000 events, extra fields) is refused as a whole with
    422, the same on HTTP, MQTT and NATS.
    """
    if not (isinstance(payload, dict) and "events" in payload and "kind" not in payload):
        return None
    try:
        return EventBatch.model_validate(payload).events
    except ValidationError as exc:
        raise Unprocessable(
            'invalid batch: send {"events": [...]} with 1 to 1000 events',
            errors=[
                {**e, "loc": ["body", *e["loc"]]} for e in validation_errors(list(exc.errors()))
            ],
        ) from None
