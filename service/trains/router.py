"""Track markers (admin) and train positions (readers)."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter
from sqlalchemy import select

from core.auth import Admin, CurrentReader
from core.database import DbSession
from service.strict_json import StrictJSONRoute
from service.trains import braking, service
from service.trains.models import TrackMarker
from service.trains.responses import TrainPositionOut
from service.trains.schemas import MarkerIn, MarkerOut

router = APIRouter(tags=["motion"], route_class=StrictJSONRoute)


@router.post("/markers", status_code=201, response_model=MarkerOut)
def create_marker(body: MarkerIn, session: DbSession, _: Admin) -> Any:
    return service.add_marker(session, body)


@router.get("/markers", response_model=list[MarkerOut])
def list_markers(session: DbSession, _: CurrentReader) -> Any:
    return session.scalars(select(TrackMarker).order_by(TrackMarker.track_m)).all()


@router.get("/trains/{train}/position", response_model=TrainPositionOut)
def train_position(train: str, session: DbSession, _: CurrentReader) -> dict[str, Any]:
    """Coordinate, speed, section and their uncertainty from the train's fused sensors."""
    return service.position(session, train)


@router.post("/motion/braking-plan", response_model=braking.BrakingPlanOut)
def braking_plan(body: braking.BrakingPlanIn, _: CurrentReader) -> braking.BrakingPlanOut:
    """Protective section and braking start point for a train (seed 001, eq. 6–7),
    as ``depot braking plan``; inputs outside the documented ranges are refused."""
    return braking.plan(body)
