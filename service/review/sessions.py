"""Server-side login sessions of the review screen, and their one-shot flash messages.

The cookie holds a random 256-bit id; the table holds its hash, who logged in, and the hash of
the token used. A session ends at logout (row deleted), at expiry, and as soon as that token is
rotated, revoked or expires: the person is looked up again on every request.
"""

from __future__ import annotations

import hmac
from datetime import datetime, timedelta

from sqlalchemy import delete, select
from sqlalchemy.orm import Session

from core.auth import Principal, hash_secret, new_secret
from core.models import User
from core.settings import get_settings
from service.review.models import ReviewSession

SESSION_HOURS = 12  # one shift; the cookie's max-age is the same
FLASH_KINDS = ("ok", "error")


def _credential_of(session: Session, token: str) -> tuple[Principal, str] | None:
    """The person a token belongs to and the hash that binds a session to that token."""
    if hmac.compare_digest(token.encode(), get_settings().admin_token.encode()):
        return Principal(role="admin", name="admin"), hash_secret(token)
    digest = hash_secret(token)
    user = session.scalar(select(User).where(User.token_hash == digest))
    if user is None:
        return None
    return Principal(role=user.role, name=user.name), digest


def _still_valid(session: Session, row: ReviewSession, now: datetime) -> bool:
    if row.expires_at <= now:
        return False
    if row.role == "admin":
        return hmac.compare_digest(row.credential_hash, hash_secret(get_settings().admin_token))
    user = session.scalar(select(User).where(User.name == row.name))
    return (
        user is not None
        and user.revoked_at is None
        and (user.expires_at is None or user.expires_at > now)
        and hmac.compare_digest(user.token_hash, row.credential_hash)
        and user.role == row.role
    )


def start(session: Session, token: str, principal: Principal, now: datetime) -> str | None:
    """A new session for a person already authenticated by ``token``; returns the cookie value."""
    found = _credential_of(session, token)
    if found is None or found[0] != principal:
        return None
    session.execute(delete(ReviewSession).where(ReviewSession.expires_at <= now))
    cookie = new_secret()
    session.add(
        ReviewSession(
            id_hash=hash_secret(cookie),
            role=principal.role,
            name=principal.name,
            credential_hash=found[1],
            created_at=now,
            expires_at=now + timedelta(hours=SESSION_HOURS),
        )
    )
    session.flush()
    return cookie


def _row(session: Session, cookie: str | None) -> ReviewSession | None:
    return session.get(ReviewSession, hash_secret(cookie)) if cookie else None


def person(session: Session, cookie: str | None, now: datetime) -> Principal | None:
    """Who holds this cookie, or None (unknown, logged out, expired, or the token changed)."""
    row = _row(session, cookie)
    if row is None or not _still_valid(session, row, now):
        return None
    return Principal(role=row.role, name=row.name)


def end(session: Session, cookie: str | None) -> None:
    """Logout: the session id stops working at once, on every worker."""
    row = _row(session, cookie)
    if row is not None:
        session.delete(row)
        session.flush()


def flash(session: Session, cookie: str | None, message: str, kind: str = "ok") -> None:
    """Keep one message for the next page this browser shows."""
    row = _row(session, cookie)
    if row is not None:
        row.flash, row.flash_kind = message[:500], kind if kind in FLASH_KINDS else "ok"
        session.flush()


def take_flash(session: Session, cookie: str | None) -> tuple[str, str] | None:
    """The waiting message and its kind, removed so that it is shown once."""
    row = _row(session, cookie)
    if row is None or row.flash is None:
        return None
    message, kind = row.flash, row.flash_kind or "ok"
    row.flash = row.flash_kind = None
    session.flush()
    return message, kind
