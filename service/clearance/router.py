"""Dispatcher API: sections, runs, decisions, audit, snapshot images."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Header, Path, Query
from fastapi.responses import FileResponse, Response
from sqlalchemy import or_, select

import tail_check
from core.auth import CurrentDispatcher, CurrentReader
from core.database import DbSession, utcnow
from core.errors import NotFound
from core.models import Section
from ingest.models import Snapshot
from ingest.snapshots import load_bgr
from service.clearance import actions
from service.clearance.models import AuditRecord, Run, WheelMarking
from service.clearance.responses import (
    AuditOut,
    DecisionAnswer,
    RunOut,
    RunsPage,
    SectionOut,
    SnapshotMetaOut,
    WheelMarkingOut,
)
from service.clearance.revision import if_match
from service.clearance.schemas import DecisionIn
from service.clearance.tail import camera_profile, snapshot_file
from service.clearance.views import audit_out, run_out, section_out
from service.strict_json import StrictJSONRoute

router = APIRouter(tags=["dispatcher"], route_class=StrictJSONRoute)
MAX_ROW_ID = 2**63 - 1
RunId = Annotated[int, Path(ge=1, le=MAX_ROW_ID, description="run id")]
SnapshotId = Annotated[int, Path(ge=1, le=MAX_ROW_ID, description="snapshot id")]


@router.get("/sections", response_model=list[SectionOut])
def list_sections(session: DbSession, _: CurrentReader) -> list[dict[str, Any]]:
    return [section_out(session, s) for s in session.scalars(select(Section).order_by(Section.id))]


@router.get("/sections/{section_id}", response_model=SectionOut)
def get_section(section_id: str, session: DbSession, _: CurrentReader) -> dict[str, Any]:
    section = session.get(Section, section_id)
    if section is None:
        raise NotFound(f"section {section_id!r} does not exist")
    return section_out(session, section)


@router.get("/runs", response_model=RunsPage)
def list_runs(
    session: DbSession,
    _: CurrentReader,
    section: str | None = None,
    state: Annotated[
        str | None, Query(description="running, arrived, conflict, or a verdict")
    ] = None,
    limit: Annotated[int, Query(ge=1, le=500)] = 50,
    cursor: Annotated[
        int | None, Query(ge=1, le=MAX_ROW_ID, description="next_cursor of the previous page")
    ] = None,
) -> dict[str, Any]:
    query = select(Run).order_by(Run.id.desc()).limit(limit + 1)
    if section:
        query = query.where(Run.section == section)
    if state:
        query = query.where(or_(Run.status == state, Run.verdict == state))
    if cursor is not None:
        query = query.where(Run.id < cursor)
    runs = session.scalars(query).all()
    page = runs[:limit]
    return {
        "items": [run_out(session, r) for r in page],
        "next_cursor": page[-1].id if len(runs) > limit else None,
    }


@router.get("/runs/{run_id}", response_model=RunOut)
def get_run(
    run_id: RunId, session: DbSession, _: CurrentReader, response: Response
) -> dict[str, Any]:
    run = session.get(Run, run_id)
    if run is None:
        raise NotFound(f"run {run_id} does not exist")
    shown = run_out(session, run)
    # What a decision sends back (If-Match) to say which look at the run it was taken on.
    response.headers["ETag"] = f'"{shown["revision"]}"'
    return shown


@router.post(
    "/runs/{run_id}/decision",
    response_model=DecisionAnswer,
    responses={
        409: {
            "description": "not the current run, not arrived, already so decided, or the run"
            " changed since the revision sent (If-Match or seen) — nothing is recorded then"
        }
    },
)
def decide_run(
    run_id: RunId,
    body: DecisionIn,
    session: DbSession,
    who: CurrentDispatcher,
    if_match_header: Annotated[
        str | None,
        Header(
            alias="If-Match",
            max_length=500,
            description="the ETag of GET /runs/{id} the decision is based on (as seen)",
        ),
    ] = None,
) -> dict[str, Any]:
    # Each look said (the header's tags, the body's field) must be the run as it is now.
    seen = [look for look in (if_match(if_match_header), [body.seen] if body.seen else []) if look]
    record = actions.act(session, run_id, body.action, body.reason, who, utcnow(), seen=seen)
    run = session.get_one(Run, run_id)
    section = session.get_one(Section, run.section)
    return {
        "audit": audit_out(record) if record else None,
        "section": section.id,
        "state": section.state,
    }


@router.get("/audit", response_model=list[AuditOut])
def list_audit(
    session: DbSession,
    _: CurrentReader,
    run: Annotated[int | None, Query(ge=1, le=MAX_ROW_ID)] = None,
    limit: Annotated[int, Query(ge=1, le=1000)] = 200,
) -> list[dict[str, Any]]:
    query = select(AuditRecord).order_by(AuditRecord.id.desc()).limit(limit)
    if run is not None:
        query = query.where(AuditRecord.run_id == run)
    return [audit_out(r) for r in session.scalars(query)]


def _snapshot(session: DbSession, snapshot_id: int) -> Snapshot:
    snapshot = session.get(Snapshot, snapshot_id)
    if snapshot is None:
        raise NotFound(f"snapshot {snapshot_id} does not exist")
    return snapshot


@router.get("/snapshots/{snapshot_id}", response_class=FileResponse)
def get_snapshot_image(snapshot_id: SnapshotId, session: DbSession, _: CurrentReader) -> Any:
    snapshot = _snapshot(session, snapshot_id)
    return FileResponse(
        snapshot_file(snapshot),
        media_type=snapshot.content_type,
        headers={"Cache-Control": "private, max-age=86400"},
    )


@router.get("/snapshots/{snapshot_id}/meta", response_model=SnapshotMetaOut)
def get_snapshot_meta(
    snapshot_id: SnapshotId, session: DbSession, _: CurrentReader
) -> dict[str, Any]:
    s = _snapshot(session, snapshot_id)
    return {
        "id": s.id,
        "device": s.device_id,
        "section": s.section,
        "run_id": s.run_id,
        "side": s.side,
        "occurred_at": s.occurred_at.isoformat(),
        "sha256": s.sha256,
        "width": s.width,
        "height": s.height,
        "verdict": s.verdict,
        "score": s.score,
        "detection": s.detection,
    }


@router.get(
    "/snapshots/{snapshot_id}/overlay",
    response_class=Response,
    responses={200: {"content": {"image/png": {}}}},
)
def get_snapshot_overlay(snapshot_id: SnapshotId, session: DbSession, _: CurrentReader) -> Response:
    """The snapshot with its stored verdict drawn on it (the one the section's decision
    used); one that was never judged (its derivation failed) is judged now."""
    snapshot = _snapshot(session, snapshot_id)
    image = load_bgr(snapshot_file(snapshot))
    if snapshot.detection:
        png = tail_check.overlay_png(image, tail_check.recorded_result(snapshot.detection))
    else:
        profile = camera_profile(snapshot.device_id)
        png = tail_check.overlay_png(image, tail_check.detect_confirmed(image, profile), profile)
    return Response(
        png, media_type="image/png", headers={"Cache-Control": "private, max-age=86400"}
    )


@router.get("/cars/{car_id}/wheel-markings", response_model=list[WheelMarkingOut])
def list_wheel_markings(car_id: str, session: DbSession, _: CurrentReader) -> list[dict[str, Any]]:
    """The marking station's results for a car: per axle written or not, state, faults."""
    rows = session.scalars(
        select(WheelMarking)
        .where(WheelMarking.car_id == car_id)
        .order_by(WheelMarking.occurred_at.desc(), WheelMarking.id.desc())
    )
    return [
        {
            "id": m.id,
            "device": m.device_id,
            "code": m.code,
            "state": m.state,
            "written": m.written,
            "faults": m.faults,
            "occurred_at": m.occurred_at.isoformat(),
        }
        for m in rows
    ]
