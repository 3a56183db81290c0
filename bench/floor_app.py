"""The reference floor of the ingest benchmark: the least a durable device endpoint can do.

A minimal FastAPI app on the same stack as depot (uvicorn, SQLAlchemy engine with psycopg,
the same pool size): ``POST /api/v1/events`` checks the ``X-Device-Key`` against the hashes
loaded at start-up, validates the body with pydantic, and does one
``INSERT … ON CONFLICT DO NOTHING RETURNING`` plus commit per request (one multi-row insert
per batch). No derivation, no liveness, no replay: what is left is the price of one durable
insert through FastAPI, which is what depot's figures are divided by.

Run by ``bench.ingest`` as ``uvicorn bench.floor_app:create_app --factory --workers 2`` with
``FLOOR_DATABASE_URL`` set; ``prepare`` creates its tables and devices.
"""

from __future__ import annotations

import hashlib
import os
from datetime import datetime
from typing import Annotated, Any, Literal

from fastapi import FastAPI, Header, HTTPException
from fastapi.responses import JSONResponse
from pydantic import BaseModel, ConfigDict, Field, ValidationError
from sqlalchemy import (
    BigInteger,
    Column,
    DateTime,
    Engine,
    MetaData,
    String,
    Table,
    create_engine,
    text,
)
from sqlalchemy.dialects import postgresql
from sqlalchemy.dialects.postgresql import JSONB

SCHEMA = """
CREATE TABLE IF NOT EXISTS floor_devices (id text PRIMARY KEY, key_hash text UNIQUE NOT NULL);
CREATE TABLE IF NOT EXISTS floor_events (
    id bigserial PRIMARY KEY,
    device_id text NOT NULL REFERENCES floor_devices (id),
    event_id text NOT NULL,
    kind text NOT NULL,
    occurred_at timestamptz NOT NULL,
    body jsonb NOT NULL,
    UNIQUE (device_id, event_id)
);
"""
EVENTS = Table(
    "floor_events",
    MetaData(),
    Column("id", BigInteger, primary_key=True),
    Column("device_id", String),
    Column("event_id", String),
    Column("kind", String),
    Column("occurred_at", DateTime(timezone=True)),
    Column("body", JSONB),
)
# One statement per request; for a list of rows SQLAlchemy sends one multi-row VALUES.
INSERT = (
    postgresql.insert(EVENTS)
    .on_conflict_do_nothing(index_elements=["device_id", "event_id"])
    .returning(EVENTS.c.id)
)


class FloorEvent(BaseModel):
    """The common fields of a protocol event, plus whatever the kind carries."""

    model_config = ConfigDict(extra="allow")
    event_id: Annotated[str, Field(min_length=1, max_length=64)]
    occurred_at: datetime
    kind: Literal["axle_count", "heartbeat"]
    section: str | None = None
    axles: Annotated[int, Field(ge=0)] | None = None


class FloorBatch(BaseModel):
    events: Annotated[list[FloorEvent], Field(min_length=1, max_length=1000)]


def key_hash(key: str) -> str:
    return hashlib.sha256(key.encode()).hexdigest()


def prepare(url: str, keys: dict[str, str]) -> None:
    """Create the floor's tables and register ``keys`` (device id -> key)."""
    engine = create_engine(url)
    with engine.begin() as connection:
        connection.exec_driver_sql(SCHEMA)
        for device, key in keys.items():
            connection.execute(
                text("INSERT INTO floor_devices VALUES (:d, :h) ON CONFLICT DO NOTHING"),
                {"d": device, "h": key_hash(key)},
            )
    engine.dispose()


def _row(device: str, event: FloorEvent, body: dict[str, Any]) -> dict[str, Any]:
    return {
        "device_id": device,
        "event_id": event.event_id,
        "kind": event.kind,
        "occurred_at": event.occurred_at,
        "body": body,
    }


def create_app() -> FastAPI:
    engine: Engine = create_engine(
        os.environ["FLOOR_DATABASE_URL"], pool_pre_ping=True, pool_size=10, max_overflow=20
    )
    with engine.connect() as connection:
        devices: dict[str, str] = dict(
            connection.execute(text("SELECT key_hash, id FROM floor_devices")).all()
        )
    app = FastAPI()

    def device_for(key: str | None) -> str:
        device: str | None = devices.get(key_hash(key)) if key else None
        if device is None:
            raise HTTPException(401, "unknown device key")
        return device

    @app.get("/healthz")
    def healthz() -> dict[str, str]:
        return {"status": "ok"}

    @app.post("/api/v1/events")
    def post_events(
        body: dict[str, Any], x_device_key: Annotated[str | None, Header()] = None
    ) -> JSONResponse:
        device = device_for(x_device_key)
        try:
            if "events" in body:
                batch = FloorBatch.model_validate(body)
                rows = [
                    _row(device, e, b) for e, b in zip(batch.events, body["events"], strict=True)
                ]
                with engine.begin() as connection:
                    stored = connection.execute(INSERT, rows).all()
                return JSONResponse({"stored": len(stored)}, status_code=200)
            event = FloorEvent.model_validate(body)
        except ValidationError as exc:
            raise HTTPException(422, str(exc)) from None
        with engine.begin() as connection:
            new = connection.execute(INSERT, _row(device, event, body)).first()
        status = 201 if new is not None else 200
        return JSONResponse({"event_id": event.event_id, "status": "created"}, status_code=status)

    return app
