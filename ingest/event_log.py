"""``GET /events``: the raw event log for operators, newest first, as the devices sent it."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from fastapi import APIRouter, Query
from pydantic import BaseModel
from sqlalchemy import select

from core.auth import CurrentDispatcher
from core.database import DbSession
from core.schemas import Instant
from ingest.models import RawEvent

router = APIRouter(tags=["operators"])
MAX_ROW_ID = 2**63 - 1
MAX_PAGE = 1000

Transport = Literal["http", "mqtt", "nats"]


class StoredEvent(BaseModel):
    """One raw event as stored: the body exactly as received, and how it arrived."""

    device: str
    event_id: str
    kind: str
    occurred_at: Instant
    received_at: Instant
    transport: Transport
    body: dict[str, Any]
    derive_error: str | None


class EventLog(BaseModel):
    items: list[StoredEvent]
    next: str | None  # pass as ``before`` for the next (older) page; null on the last page


def _item(raw: RawEvent) -> StoredEvent:
    return StoredEvent(
        device=raw.device_id,
        event_id=raw.event_id,
        kind=raw.kind,
        occurred_at=raw.occurred_at,
        received_at=raw.received_at,
        transport=raw.transport,  # the column holds only these (the migration's default: http)
        body=raw.body,
        derive_error=raw.derive_error,
    )


@router.get("/events", response_model=EventLog)
def list_events(
    session: DbSession,
    _: CurrentDispatcher,
    device: Annotated[str | None, Query(max_length=64, description="only this device")] = None,
    limit: Annotated[int, Query(ge=1, le=MAX_PAGE)] = 100,
    before: Annotated[
        int | None, Query(ge=1, le=MAX_ROW_ID, description="`next` of the previous page")
    ] = None,
) -> EventLog:
    """Stored events, newest first (in the order the service stored them)."""
    query = select(RawEvent).order_by(RawEvent.id.desc()).limit(limit + 1)
    if device is not None:
        query = query.where(RawEvent.device_id == device)
    if before is not None:
        query = query.where(RawEvent.id < before)
    rows = session.scalars(query).all()
    page = rows[:limit]
    return EventLog(
        items=[_item(r) for r in page],
        next=str(page[-1].id) if len(rows) > limit else None,
    )
