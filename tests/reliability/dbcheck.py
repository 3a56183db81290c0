"""Reading the database after a load: what was stored, and the derived state to compare."""

from __future__ import annotations

import json
from typing import Any

from sqlalchemy import create_engine, text

from tests.reliability.loadgen import Stats

# Derived tables and the columns that carry their meaning (ids are the raw events' ids).
DERIVED = {
    "sections": "id, state, current_run_id",
    "runs": "id, section, train, status, verdict, reasons, auto, arrived_at",
    "car_passages": "id, device_id, number, car_id, run_id, side",
    "axle_readings": "id, device_id, axles, run_id, side",
    "snapshots": "id, device_id, verdict, run_id, side",
    "wheel_markings": "id, car_id, state",
    "devices": "id, last_seen_at",
}


def _norm(value: Any) -> Any:
    if isinstance(value, str) and value[:1] in "[{":
        try:
            return json.loads(value)
        except ValueError:
            return value
    return value


def derived_state(url: str) -> dict[str, list[tuple[Any, ...]]]:
    engine = create_engine(url)
    try:
        with engine.connect() as connection:
            return {
                table: [
                    tuple(_norm(v) for v in row)
                    for row in connection.execute(text(f"SELECT {cols} FROM {table} ORDER BY id"))
                ]
                for table, cols in DERIVED.items()
            }
    finally:
        engine.dispose()


def stored_events(url: str) -> dict[tuple[str, str], tuple[int, Any, str | None]]:
    """(device, event_id) → (number of rows, stored body, derive_error)."""
    engine = create_engine(url)
    try:
        with engine.connect() as connection:
            counts = connection.execute(
                text("SELECT device_id, event_id, count(*) FROM raw_events GROUP BY 1, 2")
            ).all()
            rows = connection.execute(
                text("SELECT device_id, event_id, body, derive_error FROM raw_events")
            ).all()
    finally:
        engine.dispose()
    n = {(d, e): c for d, e, c in counts}
    return {(d, e): (n[(d, e)], _norm(body), err) for d, e, body, err in rows}


def assert_nothing_lost(url: str, stats: Stats) -> None:
    """Every acknowledged event is stored exactly once, as sent; nothing else was stored."""
    stored = stored_events(url)
    missing = [k for k in stats.acked if k not in stored]
    assert not missing, f"{len(missing)} acknowledged events lost, e.g. {missing[:5]}"
    twice = [k for k, (n, _, _) in stored.items() if n != 1]
    assert not twice, f"stored more than once: {twice[:5]}"
    for key, (_, body, _) in stored.items():
        sent = stats.sent.get(key)
        assert sent is not None, f"stored but never sent: {key}"
        if "kind" in sent:  # events are stored exactly as received; snapshots as their metadata
            assert body == sent, f"{key} stored with another body"


def assert_derived_cleanly(url: str) -> None:
    """No stored event failed to derive (the raw row is kept, but its effect is missing)."""
    stored = stored_events(url)
    failed = {k: err for k, (_, _, err) in stored.items() if err}
    assert not failed, f"derivations failed: {list(failed.items())[:3]}"
