"""Plausible range per maintenance parameter (values outside it are refused).

Revision ID: 0006_plausible
Revises: 0005_lifecycle
Create Date: 2026-12-01
"""

from __future__ import annotations

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0006_plausible"
down_revision: str | None = "0005_lifecycle"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    with op.batch_alter_table("maintenance_parameters") as batch:
        batch.add_column(sa.Column("plausible_lower", sa.Float(), nullable=True))
        batch.add_column(sa.Column("plausible_upper", sa.Float(), nullable=True))


def downgrade() -> None:
    with op.batch_alter_table("maintenance_parameters") as batch:
        batch.drop_column("plausible_upper")
        batch.drop_column("plausible_lower")
