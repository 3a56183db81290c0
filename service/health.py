"""Liveness and readiness."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter
from fastapi.responses import JSONResponse
from pydantic import BaseModel, Field
from sqlalchemy import text

from core.database import DbSession
from service.migrate import current_revision, head_revision

router = APIRouter(tags=["health"])


class HealthOut(BaseModel):
    status: str = Field(description="ok while the process answers")


class ReadyOut(BaseModel):
    status: str = Field(description="ready, or unavailable (503)")
    revision: str | None = Field(default=None, description="the schema's Alembic revision")
    detail: str | None = Field(default=None, description="why it is unavailable, and the fix")


@router.get("/healthz", response_model=HealthOut)
def healthz() -> HealthOut:
    return HealthOut(status="ok")


@router.get(
    "/readyz",
    response_model=ReadyOut,
    responses={503: {"model": ReadyOut, "description": "database unreachable or schema behind"}},
)
def readyz(session: DbSession) -> Any:
    try:
        connection = session.connection()
        connection.execute(text("SELECT 1"))
        revision = current_revision(connection)
    except Exception as exc:
        return JSONResponse(
            {"status": "unavailable", "detail": f"database unreachable: {type(exc).__name__}"},
            status_code=503,
            headers={"Retry-After": "5"},
        )
    head = head_revision()
    if revision != head:
        return JSONResponse(
            {
                "status": "unavailable",
                "detail": f"schema at {revision}, head is {head}; run depot migrate",
            },
            status_code=503,
        )
    return ReadyOut(status="ready", revision=revision)
