"""How each raw event arrived: ``raw_events.transport`` (``http``, ``mqtt`` or ``nats``).

Revision ID: 0003_transport
Revises: 0003_eot_sweep (re-chained after merging main; written against 0002)
Create Date: 2026-11-24

Events stored before this migration all came over HTTP, the only transport there was.
"""

from __future__ import annotations

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0003_transport"
down_revision: str | None = "0003_eot_sweep"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    with op.batch_alter_table("raw_events", schema=None) as batch_op:
        batch_op.add_column(
            sa.Column("transport", sa.String(length=8), server_default="http", nullable=False)
        )


def downgrade() -> None:
    with op.batch_alter_table("raw_events", schema=None) as batch_op:
        batch_op.drop_column("transport")
