"""The sending device of an event request, found without a thread hop when its key is cached.

The same rules and answers as the application's principal dependency (``core.auth``): an
unknown key or a decommissioned device is refused with 401, a person's token with 403. Only the
common case differs in cost: a device key whose entry is fresh in the worker's cache is checked
on the event loop, with no database session and no worker thread; everything else (a cache miss,
a bearer token) takes the general path in a thread.
"""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, Request
from fastapi.concurrency import run_in_threadpool
from fastapi.security import APIKeyHeader, HTTPAuthorizationCredentials, HTTPBearer
from fastapi.security.utils import get_authorization_scheme_param
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


def _credentials(request: Request) -> tuple[str | None, HTTPAuthorizationCredentials | None]:
    """The device key and the bearer token, read as the two schemes read them (an empty
    header is none; a bearer needs the scheme word and a token). Read here rather than as
    two ``Security`` dependencies: FastAPI's solving of dependencies was a sixth of a
    worker's CPU for single events."""
    key = request.headers.get("x-device-key") or None
    scheme, token = get_authorization_scheme_param(request.headers.get("authorization"))
    bearer = (
        HTTPAuthorizationCredentials(scheme=scheme, credentials=token)
        if scheme.lower() == "bearer" and token
        else None
    )
    return key, bearer


async def event_device(request: Request, session: DbSession) -> Device:
    """The authenticated sending device (a detached copy: read it, never write it)."""
    key, bearer = _credentials(request)
    if key and bearer is None and "authorization" not in request.headers:
        device = device_cache().peek(key)
        if device is not None:
            if device.decommissioned_at is not None:
                raise Unauthorized(f"device {device.id} is decommissioned; its events are refused")
            return device
    return await run_in_threadpool(_general, session, bearer, key)


# The schemes event_device reads, for the OpenAPI document of the routes that use it.
EVENT_SECURITY: list[dict[str, list[str]]] = [
    {_key_scheme.scheme_name: []},
    {_bearer_scheme.scheme_name: []},
]


EventDevice = Annotated[Device, Depends(event_device)]
