"""Migration 0002: measurement rows regrouped into one row per test, and split back."""

from __future__ import annotations

import json
from datetime import UTC, datetime

import sqlalchemy as sa
from alembic import command

from service.fleet.models import decode_readings
from service.migrate import alembic_config, upgrade
from tests.service import fleetkit

# The shared fixtures (pytest finds a fixture by its module's names).
url = fleetkit.url

T0 = datetime(2026, 11, 1, 7, 30, tzinfo=UTC)
T1 = datetime(2026, 11, 3, 7, 30, tzinfo=UTC)
OLD_ROWS = [  # (taken_at, parameter, value, raw_event_id, source)
    (T0, "door_close_s", 2.5, None, "api"),
    (T0, "brake_release_s", 4.1, None, "api"),
    (T0, "door_close_s", 2.6, 7, "event"),  # another test at the same time: from an event
    (T1, "brake_release_s", 4.0, None, "csv"),
    (T1, "brake_release_s", 4.2, None, "csv"),  # repeated: the later value is kept
]


def _rows(engine: sa.Engine, query: str) -> list[sa.Row]:
    with engine.connect() as connection:
        return list(connection.execute(sa.text(query)))


def test_measurements_are_regrouped_into_tests_and_split_back(url: str) -> None:
    upgrade(url, "0001")
    engine = sa.create_engine(url)
    with engine.begin() as connection:
        connection.execute(
            sa.text("INSERT INTO cars (id, axles, created_at) VALUES ('0117', 4, :at)"), {"at": T0}
        )
        for at, parameter, value, raw, source in OLD_ROWS:
            connection.execute(
                sa.text(
                    "INSERT INTO measurements (car_id, taken_at, parameter, value, raw_event_id,"
                    " source) VALUES ('0117', :at, :parameter, :value, :raw, :source)"
                ),
                {"at": at, "parameter": parameter, "value": value, "raw": raw, "source": source},
            )
    upgrade(url, "0008_received_liveness")  # 0009 stops on the two tests at T0 (its own test)
    names = dict(_rows(engine, "SELECT id, names FROM measurement_layouts"))
    tests = _rows(engine, "SELECT layout_id, readings, raw_event_id, source FROM measurements")
    stored = sorted(
        (source, raw, dict(zip(_names(names[lid]), decode_readings(data), strict=True)))
        for lid, data, raw, source in tests
    )
    assert stored == [
        ("api", None, {"brake_release_s": 4.1, "door_close_s": 2.5}),
        ("csv", None, {"brake_release_s": 4.2}),
        ("event", 7, {"door_close_s": 2.6}),
    ]
    command.downgrade(alembic_config(url), "0001")
    back = _rows(engine, "SELECT parameter, value, raw_event_id, source FROM measurements")
    assert sorted(back, key=str) == sorted(
        [
            ("door_close_s", 2.5, None, "api"),
            ("brake_release_s", 4.1, None, "api"),
            ("door_close_s", 2.6, 7, "event"),
            ("brake_release_s", 4.2, None, "csv"),
        ],
        key=str,
    )
    engine.dispose()


def _names(stored: object) -> list[str]:
    # raw SQL: a JSON column comes back as text on SQLite, decoded on PostgreSQL
    return list(json.loads(stored) if isinstance(stored, str) else stored)  # type: ignore[arg-type]
