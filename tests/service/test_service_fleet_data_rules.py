"""The measurement data rules on every way in (CSV import, engineer API): only ASCII decimal
numbers, no test dated further ahead than the events' clock skew, and one test per car and
time held by the database itself, also against two concurrent posts.

Each test failed before its fix: ``3.1_0`` and ``٣.١`` were read by ``float``, a test dated
years ahead was stored, and two concurrent posts of one test both stored a row.
"""

from __future__ import annotations

import io
import threading
from collections.abc import Callable
from datetime import datetime, timedelta
from typing import Any

import pytest
import sqlalchemy as sa
from fastapi.testclient import TestClient
from sqlalchemy import Engine, func, select
from sqlalchemy.orm import Session

from core.database import utcnow
from core.errors import Conflict
from core.settings import get_settings
from service.fleet import service as fleet_service
from service.fleet.importing import parse_tests
from service.fleet.models import Measurement, encode_readings
from service.fleet.rules import registered
from service.migrate import upgrade
from service.setup.service import create_user
from tests.service import fleetkit
from tests.service.fleetkit import HEADER, T0, measurement_count, refusal
from tests.service.linekit import build_line, register_bands

# The shared fixtures (pytest finds a fixture by its module's names).
engineer = fleetkit.engineer
keys = fleetkit.keys
url = fleetkit.url

# -- only ASCII decimal numbers ------------------------------------------------------------


@pytest.mark.parametrize(
    "cell",
    ["3.1_0", "٣.١", "３.１", "4_1", "4.1e٣"],
)
def test_csv_numbers_that_only_python_reads_are_refused(
    keys: dict, session: Session, cell: str
) -> None:
    detail = refusal(session, HEADER + f"0117,2026-11-01T07:30:00Z,2.4,{cell}\n")
    assert "line 2, column brake_release_s" in detail, detail
    assert repr(cell) in detail and "ASCII decimal" in detail, detail


def test_csv_decimal_spellings_stay_accepted(keys: dict, session: Session) -> None:
    text = HEADER + "0117,2026-11-01T07:30:00Z, 2.4 ,+4.1\n0117,2026-11-02T07:30:00Z,24e-1,4\n"
    tests = parse_tests(io.StringIO(text), registered(session))
    assert [values for _, _, values in tests] == [
        {"door_close_s": 2.4, "brake_release_s": 4.1},
        {"door_close_s": 2.4, "brake_release_s": 4.0},
    ]


# -- the events' clock skew --------------------------------------------------------------


def test_csv_test_dated_ahead_of_the_server_clock_is_refused(keys: dict, session: Session) -> None:
    skew = get_settings().max_clock_skew_s
    soon = (utcnow() + timedelta(seconds=skew / 2)).isoformat()
    ahead = (utcnow() + timedelta(days=3 * 365)).isoformat()
    detail = refusal(session, HEADER + f"0117,{soon},2.4,4.1\n0117,{ahead},2.4,4.1\n")
    assert "line 3: taken_at" in detail and "ahead of the server's clock" in detail, detail
    assert f"{skew:g} s" in detail and "DEPOT_MAX_CLOCK_SKEW_S" in detail, detail
    assert "line 2" not in detail, "within the allowed skew is accepted"


def test_api_test_dated_ahead_of_the_server_clock_is_refused(
    keys: dict, client: TestClient, session: Session, engineer: dict
) -> None:
    def post(at: datetime) -> Any:
        body = {"taken_at": at.isoformat(), "values": {"door_close_s": 2.4}}
        return client.post("/api/v1/cars/0117/measurements", json=body, headers=engineer)

    answer = post(utcnow() + timedelta(days=3 * 365))
    assert answer.status_code == 422, answer.text
    assert answer.headers["content-type"] == "application/problem+json"
    assert answer.json()["errors"][0]["loc"] == ["body", "taken_at"]
    assert "ahead of the server's clock" in answer.json()["detail"]
    assert measurement_count(session) == 0
    assert (
        post(utcnow() + timedelta(seconds=get_settings().max_clock_skew_s / 2)).status_code == 201
    )


# -- one test per car and time, held by the database --------------------------------------


def test_a_second_row_at_one_car_and_time_is_refused_by_the_database(
    keys: dict, session: Session
) -> None:
    fleet_service.record_measurements(session, "0117", T0, {"door_close_s": 2.4}, source="api")
    layout = session.scalars(select(Measurement.layout_id)).one()
    with pytest.raises(sa.exc.IntegrityError), session.begin_nested():
        session.execute(
            sa.insert(Measurement).values(
                car_id="0117", taken_at=T0, layout_id=layout, readings=encode_readings([2.5])
            )
        )


def test_the_store_answers_a_row_it_did_not_write_by_the_repeat_rule(
    keys: dict, session: Session, monkeypatch: pytest.MonkeyPatch
) -> None:
    """When another transaction stored the test between the check and the insert (seen here by
    making the first check miss it), the insert stores nothing and the rule answers."""
    fleet_service.record_measurements(session, "0117", T0, {"door_close_s": 2.4}, source="api")
    real = fleet_service.stored_test
    missed: list[bool] = []

    def first_look_misses(*args: Any) -> dict[str, float] | None:
        if not missed:
            missed.append(True)
            return None
        return real(*args)

    monkeypatch.setattr(fleet_service, "stored_test", first_look_misses)
    assert fleet_service.store_test(session, "0117", T0, {"door_close_s": 2.4}, source="api") == 0
    missed.clear()
    with pytest.raises(Conflict, match="already has a test"):
        fleet_service.store_test(session, "0117", T0, {"door_close_s": 2.6}, source="api")
    assert measurement_count(session) == 1


@pytest.mark.parametrize(
    ("second", "codes"),
    [({"door_close_s": 2.4}, [200, 201]), ({"door_close_s": 2.6}, [201, 409])],
    ids=["same-test", "other-values"],
)
def test_two_concurrent_posts_of_one_test_store_one_row(
    committed_app: Any,
    engine: Engine,
    monkeypatch: pytest.MonkeyPatch,
    second: dict[str, float],
    codes: list[int],
) -> None:
    """Both requests pass the repeat check before either stores (a barrier holds them there);
    the database keeps one row and the later request is answered by the repeat rule."""
    if engine.dialect.name != "postgresql":
        pytest.skip("SQLite takes its write lock at BEGIN: two writers never interleave")
    real: Callable[..., bool] = fleet_service.is_repeated_test
    barrier = threading.Barrier(2, timeout=20)
    waits = iter([True, True])

    def checked_then_wait(*args: Any) -> bool:
        repeated = real(*args)
        if next(waits, False):
            barrier.wait()
        return repeated

    monkeypatch.setattr(fleet_service, "is_repeated_test", checked_then_wait)
    with TestClient(committed_app) as client:
        build_line(client)
        register_bands(client)
        with sa.orm.Session(engine) as db:
            token = create_user(db, "iryna", "engineer")
            db.commit()
        headers = {"Authorization": f"Bearer {token}"}
        codes_seen: list[int] = []

        def post(values: dict[str, float]) -> None:
            body = {"taken_at": T0.isoformat(), "values": values}
            answer = client.post("/api/v1/cars/0117/measurements", json=body, headers=headers)
            codes_seen.append(answer.status_code)

        threads = [
            threading.Thread(target=post, args=(v,)) for v in ({"door_close_s": 2.4}, second)
        ]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
    assert sorted(codes_seen) == codes
    with engine.connect() as connection:
        assert connection.scalar(select(func.count()).select_from(Measurement)) == 1


# -- the migration ---------------------------------------------------------------------------


def _old_tests(url: str, rows: list[tuple[datetime, list[float], str]]) -> Engine:
    """A database at 0008 holding ``rows`` (taken_at, door and brake readings, source)."""
    upgrade(url, "0008_received_liveness")
    engine = sa.create_engine(url)
    with engine.begin() as connection:
        connection.execute(
            sa.text("INSERT INTO cars (id, axles, created_at) VALUES ('0117', 4, :at)"), {"at": T0}
        )
        connection.execute(
            sa.text("INSERT INTO measurement_layouts (id, key, names) VALUES (1, 'k', :names)"),
            {"names": '["brake_release_s", "door_close_s"]'},
        )
        for at, readings, source in rows:
            connection.execute(
                sa.text(
                    "INSERT INTO measurements (car_id, taken_at, layout_id, readings, source)"
                    " VALUES ('0117', :at, 1, :readings, :source)"
                ),
                {"at": at, "readings": encode_readings(readings), "source": source},
            )
    return engine


def test_migration_removes_exact_duplicates_keeping_the_first_then_holds_one_per_time(
    url: str,
) -> None:
    t1 = T0 + timedelta(days=1)
    engine = _old_tests(
        url,
        [
            (T0, [4.1, 2.4], "api"),
            (T0, [4.1, 2.4], "csv"),  # the same test imported again before the rule
            (t1, [4.0, 2.5], "api"),
            (T0, [4.1, 2.4], "api"),
        ],
    )
    upgrade(url)
    with engine.connect() as connection:
        kept = list(connection.execute(sa.text("SELECT id, source FROM measurements ORDER BY id")))
    assert kept == [(1, "api"), (3, "api")]
    with pytest.raises(sa.exc.IntegrityError), engine.begin() as connection:
        connection.execute(
            sa.text(
                "INSERT INTO measurements (car_id, taken_at, layout_id, readings, source)"
                " VALUES ('0117', :at, 1, :readings, 'api')"
            ),
            {"at": t1, "readings": encode_readings([4.0, 2.6])},
        )
    engine.dispose()


def test_migration_stops_on_contradicting_tests_and_names_them(url: str) -> None:
    """Two different tests at one time: which is right is for a person, not the migration."""
    engine = _old_tests(url, [(T0, [4.1, 2.4], "api"), (T0, [4.1, 2.6], "event")])
    with pytest.raises(RuntimeError) as stopped:
        upgrade(url)
    message = str(stopped.value)
    assert "car 0117" in message and "2026-11-01" in message and "ids 1, 2" in message, message
    with engine.connect() as connection:
        assert connection.scalar(sa.text("SELECT count(*) FROM measurements")) == 2
        assert connection.scalar(sa.text("SELECT version_num FROM alembic_version")) == (
            "0008_received_liveness"
        )
    engine.dispose()


# -- the engineer API reads JSON as strictly as the device protocol -------------------------


def test_api_test_repeating_a_parameter_is_refused(
    keys: dict, client: TestClient, session: Session, engineer: dict
) -> None:
    # json.loads keeps the last of two equal keys: 2.9 was stored and 2.5 silently dropped.
    body = (
        '{"taken_at": "2026-10-03T08:00:00Z", "values": {"door_close_s": 2.5, "door_close_s": 2.9}}'
    )
    answer = client.post(
        "/api/v1/cars/0117/measurements",
        content=body,
        headers={**engineer, "Content-Type": "application/json"},
    )
    assert answer.status_code == 422, answer.text
    assert answer.headers["content-type"] == "application/problem+json"
    assert "repeats the key 'door_close_s'" in answer.json()["detail"]
    assert measurement_count(session) == 0


@pytest.mark.parametrize("value", ["3.1", True, None, [3.1]])
def test_api_test_value_that_is_not_a_json_number_is_refused(
    keys: dict, client: TestClient, session: Session, engineer: dict, value: Any
) -> None:
    body = {"taken_at": "2026-10-03T08:00:00Z", "values": {"door_close_s": value}}
    answer = client.post("/api/v1/cars/0117/measurements", json=body, headers=engineer)
    assert answer.status_code == 422, answer.text
    assert answer.json()["errors"][0]["loc"][:3] == ["body", "values", "door_close_s"]
    assert measurement_count(session) == 0


def test_api_test_integer_values_stay_accepted(
    keys: dict, client: TestClient, session: Session, engineer: dict
) -> None:
    body = {"taken_at": "2026-10-03T08:00:00Z", "values": {"door_close_s": 3}}
    answer = client.post("/api/v1/cars/0117/measurements", json=body, headers=engineer)
    assert answer.status_code == 201, answer.text
