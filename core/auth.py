"""Credentials and roles: admin token, people's bearer tokens, device keys (all stored hashed)."""

from __future__ import annotations

import hashlib
import hmac
import secrets
import threading
import time
from collections.abc import Callable
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


class DeviceKeyCache:
    """Devices by the hash of their key, kept in the process for at most ``ttl_s`` seconds.

    Saves the device look-up on every event. The bound on revocation is the TTL: a key that is
    replaced, or a device that is removed, is refused by every worker at most ``ttl_s`` seconds
    later (``DEPOT_DEVICE_KEY_TTL_S``, default 2, at most 5; 0 turns the cache off), and at once
    by the worker that calls :meth:`invalidate`. Unknown keys are never cached, so a new key
    works at once. The cached devices are detached copies: read them, never write them.
    """

    def __init__(self, ttl_s: float, *, clock: Callable[[], float] = time.monotonic) -> None:
        self.ttl_s, self._clock = ttl_s, clock
        self._entries: dict[str, tuple[float, Device]] = {}
        self._lock = threading.Lock()

    def lookup(self, session: Session, key: str) -> Device | None:
        digest = hash_secret(key)
        now = self._clock()
        entry = self._entries.get(digest)
        if entry is not None and now - entry[0] < self.ttl_s:
            return entry[1]
        device = session.scalar(select(Device).where(Device.key_hash == digest))
        if device is None:
            self._entries.pop(digest, None)
            return None
        return self.remember([device], now)[0]

    def remember(self, devices: list[Device], now: float | None = None) -> list[Device]:
        """Keep detached copies of ``devices`` just read from the database (by key hash, for
        ``ttl_s``): a caller that looks many keys up with one query fills the cache too."""
        now = self._clock() if now is None else now
        copies = [
            Device(
                id=device.id,
                station=device.station,
                section=device.section,
                kind=device.kind,
                key_hash=device.key_hash,
                decommissioned_at=device.decommissioned_at,
            )
            for device in devices
        ]
        if self.ttl_s > 0:
            with self._lock:
                for copy in copies:
                    if copy.key_hash:
                        self._entries[copy.key_hash] = (now, copy)
        return copies

    def peek(self, key: str) -> Device | None:
        """The cached device of ``key`` while its entry is fresh, without touching a database
        (so an async caller can skip the thread a look-up needs); None means: look it up."""
        entry = self._entries.get(hash_secret(key))
        if entry is not None and self._clock() - entry[0] < self.ttl_s:
            return entry[1]
        return None

    def invalidate(self, device_id: str | None = None) -> None:
        """Forget one device (after its key changed) or every device."""
        with self._lock:
            for digest, (_, device) in list(self._entries.items()):
                if device_id is None or device.id == device_id:
                    del self._entries[digest]


_device_caches: dict[tuple[float, str], DeviceKeyCache] = {}


def device_cache() -> DeviceKeyCache:
    """The process's cache for the configured database, with the TTL of the settings."""
    settings = get_settings()
    scope = (settings.device_key_ttl_s, settings.resolved_database_url)
    cache = _device_caches.get(scope)
    if cache is None:
        _device_caches.clear()  # settings changed (tests): nothing cached for the old ones
        cache = _device_caches[scope] = DeviceKeyCache(scope[0])
    return cache


def device_for_key(session: Session, key: str) -> Device | None:
    """The device a key belongs to (cached, see :class:`DeviceKeyCache`), or None."""
    return device_cache().lookup(session, key)


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
        device = device_for_key(session, device_key)
        if device is None:
            raise Unauthorized("the X-Device-Key is not known; register the device to get a key")
        if device.decommissioned_at is not None:
            raise Unauthorized(f"device {device.id} is decommissioned; its events are refused")
        # The request may now read its body slowly (an image over a GPRS link): the look-up's
        # transaction ends here, so that no pooled connection waits with it (an independent
        # trial: 35 stalled uploads took every connection, and other devices got 503).
        session.commit()
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
