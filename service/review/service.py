"""What the review screen shows: sections, the queue, stale devices, one run in detail."""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime, timedelta
from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session

from core.models import Device, Section
from core.settings import get_settings
from service.clearance.models import Run
from service.clearance.views import QUEUE_STATES, run_out, section_out

STATE_WORDS = {
    "free": "free",
    "occupied": "occupied",
    "awaiting_confirmation": "awaiting confirmation",
    "review": "needs review",
    "alarm": "ALARM",
    "blocked": "blocked",
    "awaiting_sweep": "awaiting sweep",
}


@dataclass(frozen=True)
class Screen:
    sections: list[dict[str, Any]]
    queue: list[dict[str, Any]]
    stale: list[dict[str, Any]]
    recent: list[dict[str, Any]]
    run: dict[str, Any] | None


def stale_devices(session: Session, now: datetime) -> list[dict[str, Any]]:
    limit = timedelta(seconds=get_settings().heartbeat_s)
    out = []
    for device in session.scalars(select(Device).order_by(Device.id)):
        if device.kind in ("marking_station", "test_bench", "onboard_unit"):
            continue
        if device.last_seen_at is None or now - device.last_seen_at > limit:
            out.append(
                {
                    "id": device.id,
                    "kind": device.kind,
                    "station": device.station,
                    "last_seen_at": device.last_seen_at,
                }
            )
    return out


def build_screen(session: Session, *, run_id: int | None, now: datetime) -> Screen:
    sections = [
        section_out(session, s) for s in session.scalars(select(Section).order_by(Section.id))
    ]
    queue = [s for s in sections if s["state"] in QUEUE_STATES and s["run"] is not None]
    queue.sort(key=lambda s: s["state_since"] or "")
    recent_runs = session.scalars(select(Run).order_by(Run.id.desc()).limit(15)).all()
    recent = [run_out(session, r) for r in recent_runs]
    if run_id is None and queue:
        run_id = queue[0]["run"]["id"]
    found = session.get(Run, run_id) if run_id is not None else None
    return Screen(
        sections,
        queue,
        stale_devices(session, now),
        recent,
        run_out(session, found) if found else None,
    )


def aligned_rows(run: dict[str, Any]) -> list[dict[str, Any]]:
    """Consists car by car for display, one table per reader technology."""
    tables = []
    for family, comparison in sorted(run["evidence"].get("consist_comparison", {}).items()):
        rows = [{"departure": r[0], "arrival": r[1], "mark": r[2]} for r in comparison["aligned"]]
        tables.append(
            {
                "family": {"wheel": "wheel marks", "ir": "infrared"}.get(family, family),
                "status": comparison["status"],
                "rows": rows,
            }
        )
    return tables
