"""Review-screen login sessions, kept on the server (the browser holds only a random id)."""

from __future__ import annotations

from datetime import datetime

from sqlalchemy import String
from sqlalchemy.orm import Mapped, mapped_column

from core.database import Base, UTCDateTime


class ReviewSession(Base):
    """One logged-in browser. The cookie carries a random 256-bit id; only its hash is stored.

    ``credential_hash`` is the hash of the token the person logged in with: rotating or revoking
    that token ends the session at once, and logout deletes the row.
    """

    __tablename__ = "review_sessions"

    id_hash: Mapped[str] = mapped_column(String(64), primary_key=True)
    role: Mapped[str] = mapped_column(String(16))
    name: Mapped[str] = mapped_column(String(64))
    credential_hash: Mapped[str] = mapped_column(String(64))
    created_at: Mapped[datetime] = mapped_column(UTCDateTime())
    expires_at: Mapped[datetime] = mapped_column(UTCDateTime(), index=True)
    # One message for the next page the browser shows (post-redirect-get), then cleared.
    flash: Mapped[str | None] = mapped_column(String(500), nullable=True)
    flash_kind: Mapped[str | None] = mapped_column(String(8), nullable=True)
