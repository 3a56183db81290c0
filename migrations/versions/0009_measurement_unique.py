"""One test per car and time, held by the database.

Revision ID: 0009_measurement_unique
Revises: 0008_received_liveness
Create Date: 2026-12-03

A car's test is one row (0002); the service stores nothing for the very same test again and
refuses other values at a stored test's time (409), but two concurrent requests could both
pass that check and both store. The index ``ix_measurements_car_id_taken_at`` becomes unique
(``uq_measurements_car_id_taken_at``), so the second insert stores nothing and is answered by
the same rule.

Before the index, exact duplicates — rows of one car and time with the same parameters and
the same values, whatever their source — are removed, the row with the lowest id kept (the
first stored; ``depot replay`` derives an event's test again and finds it stored). Rows of one
car and time with *different* values are not chosen between: the upgrade stops, names them,
and changes nothing; a person corrects or deletes the wrong test and upgrades again.
Downgrade restores the plain index (removed duplicates are not brought back).
"""

from __future__ import annotations

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0009_measurement_unique"
down_revision: str | None = "0008_received_liveness"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None

SHOWN = 10  # contradicting tests named in the message
# Rows of a car and time with another value than their first row: these stop the upgrade.
CONTRADICTING = """
SELECT m.car_id, m.taken_at, m.id, f.id
FROM measurements m
JOIN measurements f ON f.car_id = m.car_id AND f.taken_at = m.taken_at AND f.id < m.id
WHERE NOT EXISTS (
    SELECT 1 FROM measurements e
    WHERE e.car_id = m.car_id AND e.taken_at = m.taken_at AND e.id < f.id
)
AND (f.layout_id <> m.layout_id OR f.readings <> m.readings)
ORDER BY m.car_id, m.taken_at, m.id
"""
EXACT_REPEATS = """
DELETE FROM measurements WHERE EXISTS (
    SELECT 1 FROM measurements f
    WHERE f.car_id = measurements.car_id AND f.taken_at = measurements.taken_at
    AND f.id < measurements.id
    AND f.layout_id = measurements.layout_id AND f.readings = measurements.readings
)
"""


def _refuse_contradictions(bind: sa.Connection) -> None:
    rows = list(bind.execute(sa.text(CONTRADICTING)))
    if not rows:
        return
    listed = "; ".join(
        f"car {car} at {at} (measurement ids {first}, {other})" for car, at, other, first in rows
    )
    shown = listed if len(rows) <= SHOWN else "; ".join(listed.split("; ")[:SHOWN]) + "; …"
    raise RuntimeError(
        f"depot: {len(rows)} measurement row(s) hold another test at a time their car already"
        f" has a test: {shown}. Which test is right is for a person: delete or"
        " correct the wrong row(s) (DELETE FROM measurements WHERE id = …), then run the"
        " upgrade again. Nothing was changed."
    )


def upgrade() -> None:
    bind = op.get_bind()
    _refuse_contradictions(bind)
    op.execute(EXACT_REPEATS)
    op.drop_index("ix_measurements_car_id_taken_at", table_name="measurements")
    op.create_index(
        "uq_measurements_car_id_taken_at", "measurements", ["car_id", "taken_at"], unique=True
    )


def downgrade() -> None:
    op.drop_index("uq_measurements_car_id_taken_at", table_name="measurements")
    op.create_index(
        "ix_measurements_car_id_taken_at", "measurements", ["car_id", "taken_at"], unique=False
    )
