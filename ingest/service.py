"""Idempotent storage of device events: validate, store raw, derive, report.

The public entry points, for HTTP and for the other transports (MQTT, NATS bridges):

``ingest_events(session_or_factory, device, payloads, *, transport="http")``
    Store and derive a list of raw event payloads (dicts as received) of one authenticated
    ``device``; returns one result per payload, in order, shaped like the batch answer of
    ``POST /events``: ``{"event_id", "status": "created" | "duplicate" | "rejected",
    "result"?, "error"?}``. With a session the caller commits (and must, before it tells the
    device); with a session factory the function opens a session, commits, and returns only
    after the commit. Each item stands alone, as in a batch.
``accept_event(session, device, payload, *, transport="http")``
    One payload: ``(HTTP status, answer)``; raises the 4xx errors.
``accept_batch(session, device, items, *, transport="http")``
    The batch answer's ``results`` list.
``store_group(session, items)``
    The group commit's unit: several validated events, possibly of several devices, in one
    transaction; one outcome (``(status, answer)`` or the exception) per item.
"""

from __future__ import annotations

from ingest.batch_store import accept_batch, ingest_events
from ingest.checks import (
    check_clock,
    check_device_may_send,
    check_section,
    parse_event,
    validate_event,
    validate_snapshot,
)
from ingest.group import store_group
from ingest.rows import canonical_sha256
from ingest.store import (
    accept_event,
    answer_if_stored,
    run_derivation,
    store_event,
    store_validated,
)

__all__ = [
    "accept_batch",
    "accept_event",
    "answer_if_stored",
    "canonical_sha256",
    "check_clock",
    "check_device_may_send",
    "check_section",
    "ingest_events",
    "parse_event",
    "run_derivation",
    "store_event",
    "store_group",
    "store_validated",
    "validate_event",
    "validate_snapshot",
]
