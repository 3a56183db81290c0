"""The receive-time liveness migration repairs what device clocks wrote before it (issue 17):
a device whose one event was dated 2030 is last seen when the server received that event, and
existing runs learn when the server received their departure and arrival."""

from __future__ import annotations

from datetime import datetime
from pathlib import Path

from sqlalchemy import create_engine, text

from core.database import UTCDateTime
from service.migrate import upgrade

BEFORE = "0003_transport"
NOW = "2026-11-23 10:00:00.000000"
ROWS = [
    "INSERT INTO stations (id, name, created_at) VALUES ('A', 'A', :now), ('B', 'B', :now)",
    "INSERT INTO sections (id, from_station, to_station, mode, state, created_at)"
    " VALUES ('AB', 'A', 'B', 'primary', 'free', :now)",
    "INSERT INTO devices (id, station, section, kind, key_hash, last_seen_at, created_at) VALUES"
    " ('A-ac', 'A', 'AB', 'axle_counter', 'k1', '2030-01-01 00:00:00.000000', :now),"
    " ('A-ilk', 'A', NULL, 'interlocking', 'k2', NULL, :now),"
    " ('B-ilk', 'B', NULL, 'interlocking', 'k3', NULL, :now)",
    "INSERT INTO raw_events (id, device_id, event_id, kind, occurred_at, received_at, section,"
    " body, body_sha256, result, transport) VALUES"
    " (1, 'A-ac', 'e1', 'axle_count', '2030-01-01 00:00:00.000000', :now, 'AB', '{}', 'h',"
    " '{}', 'http'),"
    " (2, 'A-ilk', 'e2', 'train_departed', '2026-11-23 09:00:00.000000',"
    " '2026-11-23 09:00:01.000000', 'AB', '{}', 'h', '{}', 'http'),"
    " (3, 'B-ilk', 'e3', 'train_arrived', '2026-11-23 09:20:00.000000',"
    " '2026-11-23 09:20:02.000000', 'AB', '{}', 'h', '{}', 'http')",
    "INSERT INTO runs (id, section, train, from_station, to_station, departed_at, arrived_at,"
    " status, reasons, auto, evidence, sweep) VALUES (2, 'AB', '2041', 'A', 'B',"
    " '2026-11-23 09:00:00.000000', '2026-11-23 09:20:00.000000', 'arrived', '[]', 1, '{}', 0)",
]


def test_last_seen_and_run_moments_come_from_receive_times(tmp_path: Path) -> None:
    url = f"sqlite:///{tmp_path / 'live.sqlite3'}"
    upgrade(url, BEFORE)
    engine = create_engine(url)
    with engine.begin() as connection:
        for statement in ROWS:
            connection.execute(text(statement), {"now": NOW})
    upgrade(url)
    as_utc = UTCDateTime().process_result_value
    with engine.connect() as connection:
        seen = connection.execute(text("SELECT id, last_seen_at FROM devices ORDER BY id")).all()
        run = connection.execute(
            text("SELECT departure_received_at, arrival_received_at FROM runs")
        ).one()
    engine.dispose()
    seen_at = {ident: str(as_utc(_parse(at), None)) for ident, at in seen}
    assert seen_at == {
        "A-ac": "2026-11-23 10:00:00+00:00",
        "A-ilk": "2026-11-23 09:00:01+00:00",
        "B-ilk": "2026-11-23 09:20:02+00:00",
    }
    assert [str(as_utc(_parse(at), None)) for at in run] == [
        "2026-11-23 09:00:01+00:00",
        "2026-11-23 09:20:02+00:00",
    ]


def _parse(value: object) -> datetime | None:
    if value is None or isinstance(value, datetime):
        return value
    return datetime.fromisoformat(str(value))
