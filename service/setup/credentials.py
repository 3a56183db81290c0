"""People's tokens and device keys over their lifetime: add, list, rotate, revoke,
decommission. Every change is an append-only `CredentialChange`; secrets are returned once
and stored only hashed. Services flush; the request (or CLI command) owns the transaction.

A rotated or revoked credential stops working at once for a person (tokens are checked on
every request); a device key's in-process cache, where there is one, forgets it within its
stated bound. There is no grace period: the old key stops with the rotation.
"""

from __future__ import annotations

import unicodedata
from datetime import datetime, timedelta

from sqlalchemy import select
from sqlalchemy.orm import Session

from core.auth import device_cache, hash_secret, new_secret
from core.database import utcnow
from core.errors import Conflict, NotFound, Unprocessable
from core.models import ROLES, CredentialChange, Device, User
from core.schemas import format_instant
from service.setup.names import DEVICE_ID, PERSON_NAME


def record_change(
    session: Session, actor: str, action: str, kind: str, subject: str, detail: str = ""
) -> None:
    session.add(
        CredentialChange(
            actor=actor, action=action, subject_kind=kind, subject=subject, detail=detail
        )
    )


def _person(session: Session, name: str) -> User:
    user = session.scalar(select(User).where(User.name == unicodedata.normalize("NFC", name)))
    if user is None:
        raise NotFound(f"user {name!r} does not exist; `depot user list` shows who does")
    return user


def _expiry(days: float | None) -> datetime | None:
    if days is None:
        return None
    if not 0 < days <= 3650:
        raise Unprocessable("a token's lifetime must be more than 0 and at most 3650 days")
    return utcnow() + timedelta(days=days)


def add_user(
    session: Session, name: str, role: str, *, actor: str, expires_in_days: float | None = None
) -> tuple[User, str]:
    """A new person with a role; returns the row and the token (shown once).

    A revoked person's name is taken again by the same row: a person who left and came back
    gets a fresh token and role (their old token stays dead), and the audit says they were
    added again. An active person is not added twice: their token is rotated instead.
    """
    name = PERSON_NAME.normalise(name)  # the API's rule, for the CLI too
    if role not in ROLES:
        raise Unprocessable(f"role must be one of {', '.join(ROLES)}")
    existing = find_person(session, name)
    if existing is not None and existing.revoked_at is None:
        raise Conflict(
            f"user {existing.name!r} already exists; rotate their token"
            f" (depot user rotate {existing.name!r})"
        )
    token = new_secret()
    if existing is not None:  # revoked: the person comes back
        revoked_at = existing.revoked_at
        assert revoked_at is not None
        existing.name, existing.role, existing.token_hash = name, role, hash_secret(token)
        existing.expires_at, existing.revoked_at = _expiry(expires_in_days), None
        detail = f"role {role}; had been revoked at {format_instant(revoked_at)}"
        record_change(session, actor, "user_readded", "user", name, detail)
        session.flush()
        return existing, token
    user = User(
        name=name, role=role, token_hash=hash_secret(token), expires_at=_expiry(expires_in_days)
    )
    session.add(user)
    record_change(session, actor, "user_added", "user", name, f"role {role}")
    session.flush()
    return user, token


def find_person(session: Session, name: str) -> User | None:
    """The person called ``name`` up to case (ЙОСИП is Йосип): one name, one person."""
    name = unicodedata.normalize("NFC", name)
    exact = session.scalar(select(User).where(User.name == name))
    if exact is not None:
        return exact
    folded = name.casefold()
    return next((u for u in session.scalars(select(User)) if u.name.casefold() == folded), None)


def list_users(session: Session) -> list[User]:
    return list(session.scalars(select(User).order_by(User.name)))


def rotate_user(
    session: Session, name: str, *, actor: str, expires_in_days: float | None = None
) -> tuple[User, str]:
    """A new token for ``name`` (a lost one is replaced); the old one stops at once."""
    user = _person(session, name)
    if user.revoked_at is not None:
        raise Conflict(
            f"user {user.name!r} was revoked; to bring them back, add them again"
            f" (depot user add {user.name!r} --role ROLE): a fresh token, audited"
        )
    token = new_secret()
    user.token_hash = hash_secret(token)
    if expires_in_days is not None:  # else the new token keeps the old one's expiry
        user.expires_at = _expiry(expires_in_days)
    elif user.expires_at is not None and user.expires_at <= utcnow():
        # Keeping a past expiry would hand out a token that is dead on arrival.
        raise Unprocessable(
            f"user {name!r}'s token expired at {format_instant(user.expires_at)}; give"
            " the new token an expiry (--expires-in-days N, or expires_in_days in the body)"
        )
    detail = "" if expires_in_days is None else f"expires in {expires_in_days:g} days"
    record_change(session, actor, "user_rotated", "user", name, detail)
    session.flush()
    return user, token


def revoke_user(session: Session, name: str, *, actor: str) -> User:
    """``name``'s token stops working at once; the person stays in the audit trail."""
    user = _person(session, name)
    if user.revoked_at is not None:
        raise Conflict(f"user {name!r} is already revoked")
    user.revoked_at = utcnow()
    # The hash is replaced too, so even a cached copy of the old token matches nothing.
    user.token_hash = hash_secret(new_secret())
    record_change(session, actor, "user_revoked", "user", name)
    session.flush()
    return user


def _device(session: Session, device_id: str) -> Device:
    device = session.get(Device, DEVICE_ID.check(device_id))
    if device is None:
        raise NotFound(f"device {device_id!r} does not exist")
    if device.decommissioned_at is not None:
        raise Conflict(f"device {device_id!r} is decommissioned; register a new device")
    return device


def rotate_device_key(session: Session, device_id: str, *, actor: str) -> tuple[Device, str]:
    """A new key for the device, shown once; the old key stops working (no grace period)."""
    device = _device(session, device_id)
    key = new_secret()
    device.key_hash = hash_secret(key)
    record_change(session, actor, "device_key_rotated", "device", device_id)
    session.flush()
    device_cache().invalidate(device_id)  # this worker at once; the others within the TTL
    return device, key


def decommission_device(session: Session, device_id: str, *, actor: str) -> Device:
    """The device's events are refused (401) from now on; its history stays."""
    device = _device(session, device_id)
    device.decommissioned_at = utcnow()
    # The key's hash stays: a device still sending with it is found and told it is
    # decommissioned (401 on HTTP, MQTT and NATS alike) rather than that its key is unknown.
    # Every path refuses a decommissioned device's key, and no key is ever issued twice.
    record_change(session, actor, "device_decommissioned", "device", device_id)
    session.flush()
    device_cache().invalidate(device_id)  # this worker at once; the others within the TTL
    return device


def changes(
    session: Session, subject: str | None = None, limit: int = 200
) -> list[CredentialChange]:
    query = select(CredentialChange).order_by(CredentialChange.id.desc()).limit(limit)
    if subject is not None:
        query = query.where(CredentialChange.subject == subject)
    return list(session.scalars(query))
