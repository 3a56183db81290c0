"""The one rule that tells a batch from a single event, shared by every transport."""

from __future__ import annotations

from typing import Annotated, Any

from annotated_types import MaxLen
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from core.errors import Unprocessable, validation_errors
from ingest.envelopes import EventBatch

# The protocol's batch size (≤ 1000 events), read from the published schema.
MAX_EVENTS = next(
    m.max_length for m in EventBatch.model_fields["events"].metadata if isinstance(m, MaxLen)
)


class _BatchShape(BaseModel):
    """A batch as a whole: ``{"events": [...]}`` with 1 to ``MAX_EVENTS`` items of any JSON
    type. Each item is judged alone afterwards (an item that is not an event object is
    rejected in its place in the results), as protocol.md says: one bad item does not drop
    the others."""

    model_config = ConfigDict(extra="forbid")
    events: Annotated[list[Any], Field(min_length=1, max_length=MAX_EVENTS)]


def batch_events(payload: Any) -> list[Any] | None:
    """The items of a batch payload (``{"events": [...]}``), or None for a single event.

    A payload is a batch when it is an object with ``events`` and no ``kind`` of its own; a
    malformed batch (``events`` not a list, empty, more than 1000 items, extra fields) is
    refused as a whole with 422, the same on HTTP, MQTT and NATS. An item that is not an
    object is no reason to refuse the batch: it is rejected alone (``ingest.batch_store``).
    """
    if not (isinstance(payload, dict) and "events" in payload and "kind" not in payload):
        return None
    try:
        return _BatchShape.model_validate(payload).events
    except ValidationError as exc:
        raise Unprocessable(
            f'invalid batch: send {{"events": [...]}} with 1 to {MAX_EVENTS} events',
            errors=[
                {**e, "loc": ["body", *e["loc"]]} for e in validation_errors(list(exc.errors()))
            ],
        ) from None
