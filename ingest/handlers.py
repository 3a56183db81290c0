"""Routing of stored raw events to the features that derive state from them.

Features register a handler per event kind (``@handles("train_arrived")``); ingestion calls them
after the raw event row is stored, and ``depot replay`` calls them again to rebuild derived tables.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from sqlalchemy.orm import Session

from core.models import Device
from ingest.liveness import touch
from ingest.models import RawEvent


@dataclass(frozen=True)
class Derivation:
    """What a handler gets: the stored row, its validated event model, and the sending device."""

    session: Session
    raw: RawEvent
    event: Any
    device: Device
    replaying: bool = False


Handler = Callable[[Derivation], dict[str, Any] | None]
HANDLERS: dict[str, list[Handler]] = {}


def handles(*kinds: str) -> Callable[[Handler], Handler]:
    def register(handler: Handler) -> Handler:
        for kind in kinds:
            HANDLERS.setdefault(kind, []).append(handler)
        return handler

    return register


def derive(derivation: Derivation) -> dict[str, Any]:
    """Run every handler of the event's kind; merge what they report for the client."""
    # Liveness has the heartbeat period's granularity: a device sending many events a second
    # need not rewrite its row for each one (decisions read staleness from the raw events).
    touch(
        derivation.session,
        derivation.device,
        derivation.raw.occurred_at,
        replaying=derivation.replaying,
    )
    result: dict[str, Any] = {}
    for handler in HANDLERS.get(derivation.raw.kind, ()):
        result.update(handler(derivation) or {})
    return result
