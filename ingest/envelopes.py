"""The envelopes of `POST /events` around the device events of `ingest.schemas`: a batch of
raw events as posted, and the acknowledgements the service answers with."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field


class EventBatch(BaseModel):
    model_config = ConfigDict(extra="forbid")
    events: Annotated[list[dict[str, Any]], Field(min_length=1, max_length=1000)]


class EventAck(BaseModel):
    event_id: str
    status: Literal["created", "duplicate"]
    model_config = ConfigDict(extra="allow")


class BatchItemResult(BaseModel):
    event_id: str | None
    status: Literal["created", "duplicate", "rejected"]
    error: dict[str, Any] | None = None
    result: dict[str, Any] | None = None


class BatchResult(BaseModel):
    results: list[BatchItemResult]
