"""Measurements stored one row per test (float64 values in a shared layout's name order).

Revision ID: 0002
Revises: 0001
Create Date: 2026-11-23

The fleet forecast job read ~4 million rows (one per parameter value) and pivoted them; a test
is now one row whose ``readings`` follow the names of its ``measurement_layouts`` row. Existing
rows are regrouped into tests (and split back on downgrade). On PostgreSQL with lz4, forecast
payloads are compressed with lz4 instead of pglz (four times cheaper to write).
"""

from __future__ import annotations

import hashlib
import json
import struct
from collections.abc import Sequence
from itertools import groupby
from typing import Any

import sqlalchemy as sa
from alembic import op

revision: str = "0002"
down_revision: str | None = "0001"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None

READINGS = sa.LargeBinary()  # little-endian float64 values, in the layout's name order
BIG_ID = sa.BigInteger().with_variant(sa.Integer(), "sqlite")

layouts = sa.table(
    "measurement_layouts",
    sa.column("id", sa.Integer),
    sa.column("key", sa.String),
    sa.column("names", sa.JSON),
)
measurements = sa.table(
    "measurements",
    sa.column("id", BIG_ID),
    sa.column("car_id", sa.String),
    sa.column("taken_at", sa.DateTime(timezone=True)),
    sa.column("parameter", sa.String),
    sa.column("value", sa.Float),
    sa.column("layout_id", sa.Integer),
    sa.column("readings", READINGS),
    sa.column("raw_event_id", BIG_ID),
    sa.column("source", sa.String),
)


def _layout(bind: sa.Connection, names: list[str], known: dict[str, int]) -> int:
    key = hashlib.sha256(json.dumps(names).encode()).hexdigest()
    if key not in known:
        found = bind.scalar(sa.select(layouts.c.id).where(layouts.c.key == key))
        if found is None:
            found = bind.execute(
                sa.insert(layouts).values(key=key, names=names).returning(layouts.c.id)
            ).scalar_one()
        known[key] = found
    return known[key]


def _group_into_tests(bind: sa.Connection) -> None:
    """Rows of one (car, time, event, source) become the first row's test; the rest go."""
    c = measurements.c
    rows = bind.execute(
        sa.select(
            c.id, c.car_id, c.taken_at, c.raw_event_id, c.source, c.parameter, c.value
        ).order_by(c.car_id, c.taken_at, c.raw_event_id, c.source, c.id)
    ).all()
    known: dict[str, int] = {}
    for _, group in groupby(rows, key=lambda r: (r.car_id, r.taken_at, r.raw_event_id, r.source)):
        test = list(group)
        values = {r.parameter: r.value for r in test}  # a repeated parameter keeps the last
        names = sorted(values)
        bind.execute(
            sa.update(measurements)
            .where(c.id == test[0].id)
            .values(
                layout_id=_layout(bind, names, known),
                readings=struct.pack(f"<{len(names)}d", *(values[n] for n in names)),
            )
        )
        if len(test) > 1:
            bind.execute(sa.delete(measurements).where(c.id.in_([r.id for r in test[1:]])))


def _lz4(bind: sa.Connection) -> bool:
    """PostgreSQL built with lz4 TOAST compression (13 and older have no column compression)."""
    if bind.dialect.name != "postgresql":
        return False
    query = "SELECT 'lz4' = ANY(enumvals) FROM pg_settings WHERE name = 'default_toast_compression'"
    return bool(bind.scalar(sa.text(query)))


def upgrade() -> None:
    if _lz4(op.get_bind()):
        # A forecast payload is ~12 kB of JSON: pglz spent ~0.5 ms compressing each (the fleet
        # job writes thousands); lz4 compresses it about four times faster.
        op.execute("ALTER TABLE forecasts ALTER COLUMN payload SET COMPRESSION lz4")
    op.create_table(
        "measurement_layouts",
        sa.Column("id", sa.Integer(), autoincrement=True, nullable=False),
        sa.Column("key", sa.String(length=64), nullable=False),
        sa.Column("names", sa.JSON(), nullable=False),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_measurement_layouts")),
        sa.UniqueConstraint("key", name=op.f("uq_measurement_layouts_key")),
    )
    with op.batch_alter_table("measurements", schema=None) as batch_op:
        batch_op.add_column(sa.Column("layout_id", sa.Integer(), nullable=True))
        batch_op.add_column(sa.Column("readings", READINGS, nullable=True))
    _group_into_tests(op.get_bind())
    with op.batch_alter_table("measurements", schema=None) as batch_op:
        batch_op.alter_column("layout_id", existing_type=sa.Integer(), nullable=False)
        batch_op.alter_column("readings", existing_type=READINGS, nullable=False)
        batch_op.create_foreign_key(
            batch_op.f("fk_measurements_layout_id_measurement_layouts"),
            "measurement_layouts",
            ["layout_id"],
            ["id"],
        )
        batch_op.drop_index(batch_op.f("ix_measurements_car_id"))
        batch_op.create_index(
            "ix_measurements_car_id_taken_at", ["car_id", "taken_at"], unique=False
        )
        batch_op.drop_column("parameter")
        batch_op.drop_column("value")


def _split_tests(bind: sa.Connection) -> None:
    """Each test back to one row per value (the test's row keeps its first value)."""
    c = measurements.c
    names = dict(bind.execute(sa.select(layouts.c.id, layouts.c.names)).all())
    tests = bind.execute(
        sa.select(c.id, c.car_id, c.taken_at, c.raw_event_id, c.source, c.layout_id, c.readings)
    ).all()
    for test in tests:
        stored = names[test.layout_id]
        readings = struct.unpack(f"<{len(stored)}d", test.readings)
        pairs = list(zip(stored, readings, strict=True))
        first, rest = pairs[0], pairs[1:]
        bind.execute(
            sa.update(measurements)
            .where(c.id == test.id)
            .values(parameter=first[0], value=float(first[1]))
        )
        extra: list[dict[str, Any]] = [
            {"car_id": test.car_id, "taken_at": test.taken_at, "parameter": name,
             "value": float(value), "raw_event_id": test.raw_event_id, "source": test.source,
             "layout_id": test.layout_id, "readings": test.readings}  # dropped right after
            for name, value in rest
        ]  # fmt: skip
        if extra:
            bind.execute(sa.insert(measurements), extra)


def downgrade() -> None:
    if _lz4(op.get_bind()):
        op.execute("ALTER TABLE forecasts ALTER COLUMN payload SET COMPRESSION default")
    with op.batch_alter_table("measurements", schema=None) as batch_op:
        batch_op.add_column(sa.Column("parameter", sa.String(length=64), nullable=True))
        batch_op.add_column(sa.Column("value", sa.Float(), nullable=True))
    _split_tests(op.get_bind())
    with op.batch_alter_table("measurements", schema=None) as batch_op:
        batch_op.alter_column("parameter", existing_type=sa.String(length=64), nullable=False)
        batch_op.alter_column("value", existing_type=sa.Float(), nullable=False)
        batch_op.drop_index("ix_measurements_car_id_taken_at")
        batch_op.create_index(batch_op.f("ix_measurements_car_id"), ["car_id"], unique=False)
        batch_op.drop_constraint(
            batch_op.f("fk_measurements_layout_id_measurement_layouts"), type_="foreignkey"
        )
        batch_op.drop_column("readings")
        batch_op.drop_column("layout_id")
    op.drop_table("measurement_layouts")
