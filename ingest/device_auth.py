"""The sending device of an event request, found without a thread hop when its key is cached.

The same rules and answers as the application's principal dependency (``core.auth``): an
unknown key or a decommissioned device is refused with 401, a person's token with 403. Only the
common case differs in cost: a device key whose entry is fresh in the worker's cache is checked
on the event loop, with no database session and no worker thread; everything else (a cache miss,
a bearer token) takes the general path in a thread.
"""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, Request, Security
from fastapi.concurrency import run_in_threadpool
from fastapi.security import APIKeyHeader, HTTPAuthorizationCredentials, HTTPBearer
from sqlalchemy.orm import Session

from core.auth import device_cache, get_principal
from core.database import DbSession
from core.errors import Forbidden, Unauthorized
from core.models import Device

# Declared for the OpenAPI document (the same schemes as core.auth); read here directly.
_key_scheme = APIKeyHeader(name="X-Device-Key", auto_error=False, description="device key")
_bearer_scheme = HTTPBearer(auto_error=False, description="admin token or a person's token")


def _general(
    session: Session, bearer: HTTPAuthorizationCredentials | None, key: str | None
) -> Device:
    principal = get_principal(session, bearer, key)
    if principal.role != "device" or principal.device is None:
        raise Forbidden(f"this action needs the role device; you are {principal.role}")
    return principal.device


async def event_device(
    request: Request,
    session: DbSession,
    key: Annotated[str | None, Security(_key_scheme)],
    bearer: Annotated[HTTPAuthorizationCredentials | None, Security(_bearer_scheme)],
) -> Device:
    """The authenticated sending device (a detached copy: read it, never write it)."""
    if key and bearer is None and "authorization" not in request.headers:
        device = device_cache().peek(key)
        if device is not None:
            if device.decommissioned_at is not None:
                raise Unauthorized(f"device {device.id} is decommissioned; its events are refused")
            return device
    return await run_in_threadpool(_general, session, bearer, key)


EventDevice = Annotated[Device, Depends(event_device)]
