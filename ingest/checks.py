"""The checks of a device event that come before anything is stored.

Schema (422 naming the fields), the device's clock (422 when too far ahead), the device kind's
permission (403) and the section rule (422); nothing here writes.
"""

from __future__ import annotations

from datetime import datetime, timedelta
from typing import Any

from pydantic import ValidationError
from sqlalchemy.orm import Session

from core.database import utcnow
from core.errors import Forbidden, Unprocessable, validation_errors
from core.models import Device, Section
from core.schemas import format_instant
from core.settings import get_settings
from ingest.schemas import (
    ALLOWED_KINDS,
    EVENT_ADAPTER,
    EVENT_KINDS,
    EVENT_LIST_ADAPTER,
    TailSnapshot,
)


def parse_event(payload: Any) -> Any:
    """Validate one event against the schema of its kind; 422 names the offending fields."""
    event = _parse_schema(payload)
    check_clock(event, utcnow())
    return event


def parse_events(payloads: list[Any]) -> list[Any] | None:
    """The events of a batch's items validated in one pass (the clock is checked per item
    afterwards, by :func:`check_clock`), or None when any item is not a valid event: then
    each is judged alone by :func:`parse_event`, which names its faults."""
    for payload in payloads:
        if not isinstance(payload, dict) or payload.get("kind") not in EVENT_KINDS:
            return None
    try:
        return EVENT_LIST_ADAPTER.validate_python(payloads)
    except ValidationError:
        return None


def _parse_schema(payload: Any) -> Any:
    if not isinstance(payload, dict):
        raise Unprocessable(
            "an event must be a JSON object", errors=[{"loc": ["body"], "msg": "not an object"}]
        )
    kind = payload.get("kind")
    if kind is None:
        raise Unprocessable(
            f"the field 'kind' is missing; expected one of {', '.join(EVENT_KINDS)}",
            errors=[{"loc": ["body", "kind"], "msg": "field required"}],
        )
    if kind not in EVENT_KINDS:
        raise Unprocessable(
            f"unknown event kind {kind!r}; expected one of {', '.join(EVENT_KINDS)}",
            errors=[{"loc": ["body", "kind"], "msg": "unknown event kind"}],
        )
    try:
        event = EVENT_ADAPTER.validate_python(payload)
    except ValidationError as exc:
        errors = validation_errors(list(exc.errors()))
        for error in errors:
            # The discriminator adds the kind as the first location step; the field is what matters.
            if len(error["loc"]) > 1 and error["loc"][0] == kind:
                error["loc"] = error["loc"][1:]
            error["loc"] = ["body", *error["loc"]]
        fields = ", ".join(".".join(e["loc"][1:]) for e in errors[:5])
        raise Unprocessable(f"invalid {kind} event: {fields}", errors=errors) from None
    return event


def check_clock(event: Any, now: datetime) -> None:
    """Refuse an event from a device clock running ahead of the server's by more than
    ``DEPOT_MAX_CLOCK_SKEW_S``: a clock set to 2030 would otherwise keep its device "alive"
    for years and put evidence into runs that have not happened yet."""
    if event.occurred_at > latest_allowed(now):
        skew = get_settings().max_clock_skew_s
        ahead = (event.occurred_at - now).total_seconds()
        raise Unprocessable(
            f"occurred_at {format_instant(event.occurred_at)} is {ahead:.0f} s ahead of the"
            f" server's clock ({format_instant(now.replace(microsecond=0))}); at most {skew:g} s"
            " is allowed: set the device's clock (NTP) and send the event again",
            errors=[{"loc": ["body", "occurred_at"], "msg": "ahead of the server's clock"}],
        )


def latest_allowed(now: datetime) -> datetime:
    """The latest ``occurred_at`` :func:`check_clock` accepts at server time ``now``."""
    return now + timedelta(seconds=get_settings().max_clock_skew_s)


def check_device_may_send(device: Device, kind: str) -> None:
    if kind not in ALLOWED_KINDS.get(device.kind, frozenset()):
        raise Forbidden(f"a {device.kind} device may not send {kind} events")


def check_section(session: Session, device: Device, section_id: str | None) -> None:
    """The protocol's rule: a device's own section, or one starting/ending at its station."""
    if section_id is None:
        return
    loc = {"loc": ["body", "section"], "msg": "section not served by this device"}
    if device.section is not None:
        if section_id != device.section:
            raise Unprocessable(
                f"device {device.id} serves section {device.section}, not {section_id!r}",
                errors=[loc],
            )
        return
    section = session.get(Section, section_id)
    if section is None or device.station not in (section.from_station, section.to_station):
        raise Unprocessable(
            f"section {section_id!r} does not start or end at station {device.station}",
            errors=[loc],
        )


def validate_event(device: Device, payload: Any) -> Any:
    """The checks that need no database: schema and the device kind's permission."""
    event = parse_event(payload)
    check_device_may_send(device, event.kind)
    return event


def validate_snapshot(session: Session, device: Device, payload: dict[str, Any]) -> TailSnapshot:
    """Validate the event of an uploaded tail-car image before anything is written."""
    try:
        event = TailSnapshot.model_validate(payload)
    except ValidationError as exc:
        errors = [{**e, "loc": ["body", *e["loc"]]} for e in validation_errors(list(exc.errors()))]
        fields = ", ".join(".".join(e["loc"][1:]) for e in errors[:5])
        raise Unprocessable(f"invalid snapshot: {fields}", errors=errors) from None
    check_device_may_send(device, event.kind)
    check_clock(event, utcnow())
    check_section(session, device, event.section)
    return event
