"""A run that departed into a section not cleared, and the arrival event that closed a run.

Revision ID: 0011_run_conflict
Revises: 0010_arrival_train
Create Date: 2026-12-02

A train departing into a section that was not cleared was recorded only by its status
(``conflict``), which its arrival had to change: the words of the conflict were lost at the
first re-decision, so the run could be decided ``complete`` without a person. ``runs.conflict``
keeps them, and every decision of the run derives "a person must look" from them.
``runs.arrival_id`` is the raw id of the ``train_arrived`` that closed the run, so that an
arrival which reached depot before its departure is found (and taken) by that departure.
Existing runs keep both empty; ``depot replay`` derives them from the raw events.
"""

from __future__ import annotations

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0011_run_conflict"
down_revision: str | None = "0010_arrival_train"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    with op.batch_alter_table("runs", schema=None) as batch_op:
        batch_op.add_column(sa.Column("conflict", sa.Text(), nullable=True))
        batch_op.add_column(
            sa.Column(
                "arrival_id",
                sa.BigInteger().with_variant(sa.Integer(), "sqlite"),
                nullable=True,
            )
        )


def downgrade() -> None:
    with op.batch_alter_table("runs", schema=None) as batch_op:
        batch_op.drop_column("arrival_id")
        batch_op.drop_column("conflict")
