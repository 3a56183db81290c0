"""``GET /metrics``: Prometheus text format, for the admin token or ``DEPOT_METRICS_TOKEN``.

This worker's counters (``core/metrics.py``: events by kind and outcome, decision latency)
and gauges read from the database at scrape time, the same from every worker: devices stale
past their heartbeat, sections by state and the review queue (runs waiting for a person).
"""

from __future__ import annotations

import hmac

from fastapi import APIRouter, Request
from fastapi.responses import PlainTextResponse
from sqlalchemy import func, select
from sqlalchemy.orm import Session

from core import metrics
from core.auth import device_for_key, person_for_token
from core.database import DbSession, utcnow
from core.errors import Forbidden, Unauthorized
from core.models import Section
from core.settings import get_settings
from service.clearance.views import QUEUE_STATES
from service.review.service import stale_devices

router = APIRouter(tags=["operations"])
PROMETHEUS_TEXT = "text/plain; version=0.0.4; charset=utf-8"


def _authorised(request: Request, session: Session) -> None:
    """The admin token or DEPOT_METRICS_TOKEN; anyone else known (a person, a device) is 403,
    as on every other route, and unknown credentials are 401."""
    settings = get_settings()
    given = request.headers.get("authorization", "")
    scheme, _, token = given.partition(" ")
    accepted = [settings.admin_token, *([settings.metrics_token] if settings.metrics_token else [])]
    if scheme.lower() == "bearer" and any(
        hmac.compare_digest(token.encode(), secret.encode()) for secret in accepted
    ):
        return
    device_key = request.headers.get("x-device-key")
    known = (scheme.lower() == "bearer" and person_for_token(session, token) is not None) or (
        device_key is not None and device_for_key(session, device_key) is not None
    )
    if known:
        raise Forbidden("/metrics is for the admin token or DEPOT_METRICS_TOKEN")
    raise Unauthorized("send the admin token or DEPOT_METRICS_TOKEN as a bearer token")


def _gauge(name: str, help_text: str, samples: dict[str, float], label: str = "") -> list[str]:
    lines = [f"# HELP {name} {help_text}", f"# TYPE {name} gauge"]
    for value_label, value in sorted(samples.items()):
        where = f'{{{label}="{value_label}"}}' if label else ""
        lines.append(f"{name}{where} {value:g}")
    return lines


def database_gauges(session: Session) -> list[str]:
    """Stale devices (the review screen's list, by the one liveness rule
    :func:`ingest.liveness.stale_devices`), sections by state, the review queue."""
    stale = len(stale_devices(session, utcnow()))
    states = {
        state: float(n)
        for state, n in session.execute(select(Section.state, func.count()).group_by(Section.state))
    }
    queue = sum(n for state, n in states.items() if state in QUEUE_STATES)
    return [
        *_gauge("depot_devices_stale", "devices silent past DEPOT_HEARTBEAT_S", {"": stale}),
        *_gauge("depot_sections", "block sections by state", states, "state"),
        *_gauge("depot_review_queue", "sections waiting for a dispatcher", {"": queue}),
    ]


@router.get("/metrics", response_class=PlainTextResponse, responses={401: {}, 403: {}})
def prometheus_metrics(request: Request, session: DbSession) -> PlainTextResponse:
    """Prometheus text exposition (version 0.0.4)."""
    _authorised(request, session)
    return PlainTextResponse(metrics.render(database_gauges(session)), media_type=PROMETHEUS_TEXT)
