"""The train number an arrival reported, kept on its run.

Revision ID: 0010_arrival_train
Revises: 0009_measurement_unique
Create Date: 2026-12-03

A ``train_arrived`` naming another train than the departure made the run undetermined, but
the number was only handed to that first decision: late evidence re-decided the run without
it (a late tail photo could free the section). ``runs.arrival_train`` keeps it, so every
re-decision derives the mismatch again. Existing arrived runs are filled from their arrival's
raw event (by section and device time, as 0008 finds ``arrival_received_at``); ``depot replay``
writes it again from the raw events.
"""

from __future__ import annotations

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0010_arrival_train"
down_revision: str | None = "0009_measurement_unique"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None

RUNS = sa.table(
    "runs",
    sa.column("id", sa.BigInteger),
    sa.column("section", sa.String),
    sa.column("arrived_at", sa.DateTime(timezone=True)),
    sa.column("arrival_train", sa.String),
)
RAW = sa.table(
    "raw_events",
    sa.column("id", sa.BigInteger),
    sa.column("kind", sa.String),
    sa.column("section", sa.String),
    sa.column("occurred_at", sa.DateTime(timezone=True)),
    sa.column("body", sa.JSON),
)


def _fill(bind: sa.Connection) -> None:
    arrivals = {
        (section, at): body
        for section, at, body in bind.execute(
            sa.select(RAW.c.section, RAW.c.occurred_at, RAW.c.body)
            .where(RAW.c.kind == "train_arrived")
            .order_by(RAW.c.id.desc())  # the first arrival of a section and time wins
        )
    }
    runs = bind.execute(
        sa.select(RUNS.c.id, RUNS.c.section, RUNS.c.arrived_at).where(
            RUNS.c.arrived_at.is_not(None)
        )
    )
    for run_id, section, at in list(runs):
        body = arrivals.get((section, at))
        train = body.get("train") if isinstance(body, dict) else None
        if isinstance(train, str):
            bind.execute(
                sa.update(RUNS).where(RUNS.c.id == run_id).values(arrival_train=train[:32])
            )


def upgrade() -> None:
    with op.batch_alter_table("runs", schema=None) as batch_op:
        batch_op.add_column(sa.Column("arrival_train", sa.String(length=32), nullable=True))
    _fill(op.get_bind())


def downgrade() -> None:
    with op.batch_alter_table("runs", schema=None) as batch_op:
        batch_op.drop_column("arrival_train")
