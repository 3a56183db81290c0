"""Clear after a sweep train and EOT telemetry: sweep links and the armed EOT unit on runs;
the table of EOT radio reports.

Revision ID: 0003_eot_sweep
Revises: 0006_plausible
Create Date: 2026-11-24
"""

from __future__ import annotations

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0003_eot_sweep"
down_revision: str | None = "0006_plausible"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None

BIG_ID = sa.BigInteger().with_variant(sa.Integer(), "sqlite")


def upgrade() -> None:
    with op.batch_alter_table("runs", schema=None) as batch_op:
        batch_op.add_column(
            sa.Column("sweep", sa.Boolean(), nullable=False, server_default=sa.false())
        )
        batch_op.add_column(sa.Column("sweep_of", BIG_ID, nullable=True))
        batch_op.add_column(sa.Column("cleared_by", BIG_ID, nullable=True))
        batch_op.add_column(sa.Column("eot_unit", sa.Integer(), nullable=True))
    op.create_table(
        "eot_reports",
        sa.Column("id", BIG_ID, autoincrement=False, nullable=False),
        sa.Column("device_id", sa.String(length=64), nullable=False),
        sa.Column("station", sa.String(length=32), nullable=False),
        sa.Column("section", sa.String(length=32), nullable=False),
        sa.Column("occurred_at", sa.DateTime(timezone=True), nullable=False),
        sa.Column("unit_address", sa.Integer(), nullable=False),
        sa.Column("pressure_psig", sa.Integer(), nullable=False),
        sa.Column("motion", sa.Boolean(), nullable=True),
        sa.Column("marker_light", sa.Boolean(), nullable=True),
        sa.Column("battery_charge", sa.Integer(), nullable=True),
        sa.Column("bits", sa.String(length=74), nullable=True),
        sa.Column("run_id", BIG_ID, nullable=True),
        sa.Column("side", sa.String(length=16), nullable=True),
        sa.ForeignKeyConstraint(
            ["device_id"], ["devices.id"], name=op.f("fk_eot_reports_device_id_devices")
        ),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_eot_reports")),
    )
    with op.batch_alter_table("eot_reports", schema=None) as batch_op:
        batch_op.create_index(batch_op.f("ix_eot_reports_run_id"), ["run_id"], unique=False)
        batch_op.create_index(batch_op.f("ix_eot_reports_section"), ["section"], unique=False)


def downgrade() -> None:
    with op.batch_alter_table("eot_reports", schema=None) as batch_op:
        batch_op.drop_index(batch_op.f("ix_eot_reports_section"))
        batch_op.drop_index(batch_op.f("ix_eot_reports_run_id"))
    op.drop_table("eot_reports")
    with op.batch_alter_table("runs", schema=None) as batch_op:
        batch_op.drop_column("eot_unit")
        batch_op.drop_column("cleared_by")
        batch_op.drop_column("sweep_of")
        batch_op.drop_column("sweep")
