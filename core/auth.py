"""Credentials and roles: admin token, people's bearer tokens, device keys (all stored hashed)."""

from __future__ import annotations

import hashlib
import hmac
import secrets
from dataclasses import dataclass
from typing import Annotated

from fastapi import Depends
from fastapi.security import APIKeyHeader, HTTPAuthorizationCredentials, HTTPBearer
from sqlalchemy import select
from sqlalchemy.orm import Session

from core.database import DbSession, utcnow
from core.errors import Forbidden, Unauthorized
from core.models import Device, User
from core.settings import get_settings

_bearer = HTTPBearer(auto_error=False, description="admin token or a person's token")
_device_key = APIKeyHeader(name="X-Device-Key", auto_error=False, description="device key")


def new_secret() -> str:
    """A fresh random credential (256 bits), shown once to its owner."""
    return secrets.token_urlsafe(32)


def hash_secret(secret: str) -> str:
    # Credentials are 256-bit random strings, so a fast digest is enough; no password stretching.
    return hashlib.sha256(secret.encode()).hexdigest()


@dataclass(frozen=True)
class Principal:
    role: str  # "admin" | "dispatcher" | "engineer" | "device"
    name: str
    device: Device | None = None


def person_for_token(session: Session, token: str) -> Principal | None:
    """The person (or admin) a bearer token belongs to, or None."""
    if hmac.compare_digest(token.encode(), get_settings().admin_token.encode()):
        return Principal(role="admin", name="admin")
    user = session.scalar(select(User).where(User.token_hash == hash_secret(token)))
    if user is None or user.revoked_at is not None:
        return None
    if user.expires_at is not None and user.expires_at <= utcnow():
        return None
    return Principal(role=user.role, name=user.name)


def get_principal(
    session: DbSession,
    bearer: Annotated[HTTPAuthorizationCredentials | None, Depends(_bearer)],
    device_key: Annotated[str | None, Depends(_device_key)],
) -> Principal:
    if bearer is not None:
        person = person_for_token(session, bearer.credentials)
        if person is None:
            raise Unauthorized(
                "the bearer token is not known, expired or revoked; ask an administrator for a"
                " new one (depot user rotate NAME)"
            )
        return person
    if device_key:
        device = session.scalar(select(Device).where(Device.key_hash == hash_secret(device_key)))
        if device is None:
            raise Unauthorized("the X-Device-Key is not known; register the device to get a key")
        if device.decommissioned_at is not None:
            raise Unauthorized(f"device {device.id} is decommissioned; its events are refused")
        return Principal(role="device", name=device.id, device=device)
    raise Unauthorized("credentials required: 'Authorization: Bearer <token>' or 'X-Device-Key'")


def _requires(*roles: str):  # type: ignore[no-untyped-def]
    def dependency(principal: Annotated[Principal, Depends(get_principal)]) -> Principal:
        if principal.role not in roles:
            raise Forbidden(
                f"this action needs the role {' or '.join(roles)}; you are {principal.role}"
            )
        return principal

    return dependency


CurrentPrincipal = Annotated[Principal, Depends(get_principal)]
Admin = Annotated[Principal, Depends(_requires("admin"))]
CurrentReader = Annotated[Principal, Depends(_requires("admin", "dispatcher", "engineer"))]
CurrentDispatcher = Annotated[Principal, Depends(_requires("admin", "dispatcher"))]
CurrentEngineer = Annotated[Principal, Depends(_requires("admin", "engineer"))]
CurrentDevicePrincipal = Annotated[Principal, Depends(_requires("device"))]
