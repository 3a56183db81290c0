"""Liveness from the server's receive times (issue 17).

Revision ID: 0008_received_liveness
Revises: 0007_review_sessions
Create Date: 2026-12-02

- ``devices.last_seen_at`` now means when the server last received anything from the device;
  existing values (device times: one event dated 2030 kept a device alive for years) are
  recomputed from the raw events' ``received_at``.
- ``runs.departure_received_at`` / ``arrival_received_at``: when the server received the
  departure and the arrival, the moments at which each side's devices' silence is judged.
  Filled for existing runs from their raw events (the arrival by section and device time);
  ``depot replay`` writes them again from the raw events.
- The index serving "latest event of a device before t" moves from ``occurred_at`` to
  ``received_at``, the column that question is now asked of.
"""

from __future__ import annotations

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0008_received_liveness"
down_revision: str | None = "0007_review_sessions"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None

LAST_RECEIVED = (
    "UPDATE devices SET last_seen_at ="
    " (SELECT max(r.received_at) FROM raw_events r WHERE r.device_id = devices.id)"
)
DEPARTURE_RECEIVED = (
    "UPDATE runs SET departure_received_at ="
    " (SELECT r.received_at FROM raw_events r WHERE r.id = runs.id)"
)
ARRIVAL_RECEIVED = (
    "UPDATE runs SET arrival_received_at ="
    " (SELECT min(r.received_at) FROM raw_events r WHERE r.kind = 'train_arrived'"
    " AND r.section = runs.section AND r.occurred_at = runs.arrived_at)"
    " WHERE arrived_at IS NOT NULL"
)


def upgrade() -> None:
    with op.batch_alter_table("runs", schema=None) as batch_op:
        batch_op.add_column(
            sa.Column("departure_received_at", sa.DateTime(timezone=True), nullable=True)
        )
        batch_op.add_column(
            sa.Column("arrival_received_at", sa.DateTime(timezone=True), nullable=True)
        )
    with op.batch_alter_table("raw_events", schema=None) as batch_op:
        batch_op.drop_index("ix_raw_events_device_id_occurred_at")
        batch_op.create_index(
            "ix_raw_events_device_id_received_at", ["device_id", "received_at"], unique=False
        )
    for statement in (LAST_RECEIVED, DEPARTURE_RECEIVED, ARRIVAL_RECEIVED):
        op.execute(statement)


def downgrade() -> None:
    with op.batch_alter_table("raw_events", schema=None) as batch_op:
        batch_op.drop_index("ix_raw_events_device_id_received_at")
        batch_op.create_index(
            "ix_raw_events_device_id_occurred_at", ["device_id", "occurred_at"], unique=False
        )
    with op.batch_alter_table("runs", schema=None) as batch_op:
        batch_op.drop_column("arrival_received_at")
        batch_op.drop_column("departure_received_at")
