"""Admin API of the credential lifecycle: people (``/users``) and device keys."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Body, Query

from core.auth import Admin
from core.database import DbSession
from service.setup import credentials
from service.setup.schemas import (
    CredentialChangeOut,
    DeviceDecommissioned,
    DeviceKey,
    TokenRotateIn,
    UserIn,
    UserOut,
    UserToken,
)
from service.strict_json import StrictJSONRoute

router = APIRouter(tags=["credentials"], route_class=StrictJSONRoute)


def _token_out(user: Any, token: str) -> UserToken:
    return UserToken.model_validate({**UserOut.model_validate(user).model_dump(), "token": token})


@router.get("/users", response_model=list[UserOut])
def list_users(session: DbSession, _: Admin) -> Any:
    return credentials.list_users(session)


@router.post("/users", status_code=201, response_model=UserToken, responses={409: {}})
def add_user(body: UserIn, session: DbSession, who: Admin) -> UserToken:
    user, token = credentials.add_user(
        session, body.name, body.role, actor=who.name, expires_in_days=body.expires_in_days
    )
    return _token_out(user, token)


@router.post("/users/{name}/rotate", response_model=UserToken, responses={404: {}, 409: {}})
def rotate_user(
    name: str, session: DbSession, who: Admin, body: TokenRotateIn | None = Body(default=None)
) -> UserToken:
    days = body.expires_in_days if body else None
    user, token = credentials.rotate_user(session, name, actor=who.name, expires_in_days=days)
    return _token_out(user, token)


@router.post("/users/{name}/revoke", response_model=UserOut, responses={404: {}, 409: {}})
def revoke_user(name: str, session: DbSession, who: Admin) -> Any:
    return credentials.revoke_user(session, name, actor=who.name)


@router.post("/devices/{device_id}/key", response_model=DeviceKey, responses={404: {}, 409: {}})
def rotate_device_key(device_id: str, session: DbSession, who: Admin) -> DeviceKey:
    device, key = credentials.rotate_device_key(session, device_id, actor=who.name)
    return DeviceKey(device=device.id, key=key)


@router.post(
    "/devices/{device_id}/decommission",
    response_model=DeviceDecommissioned,
    responses={404: {}, 409: {}},
)
def decommission_device(device_id: str, session: DbSession, who: Admin) -> DeviceDecommissioned:
    device = credentials.decommission_device(session, device_id, actor=who.name)
    assert device.decommissioned_at is not None
    return DeviceDecommissioned(device=device.id, decommissioned_at=device.decommissioned_at)


@router.get("/credential-changes", response_model=list[CredentialChangeOut])
def list_changes(
    session: DbSession,
    _: Admin,
    subject: str | None = None,
    limit: Annotated[int, Query(ge=1, le=1000)] = 200,
) -> Any:
    return credentials.changes(session, subject, limit)
