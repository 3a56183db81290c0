"""Defects an independent trial found in the measurement rules and the fleet ranking.

Each test failed before its fix: a decimal comma read as two numbers, contradictory CSV rows
merged, a changed value at the same (car, taken_at) stored beside the old one, refused event
values acknowledged with 201, an inverted plausible range accepted, and a car already out of
tolerance ranked as serviceable below cars inside their bands.
"""

from __future__ import annotations

import io
from datetime import datetime, timedelta

import numpy as np
import pytest
from fastapi.testclient import TestClient
from sqlalchemy import select
from sqlalchemy.orm import Session

from ingest.models import RawEvent
from service.fleet import views
from service.fleet.calibration import FleetIndex
from service.fleet.forecasts import ForecastOptions, forecast_row
from service.fleet.history import CarHistory, load_bands
from service.fleet.importing import parse_tests
from service.fleet.models import Forecast
from service.fleet.rules import registered
from tests.service import fleetkit
from tests.service.fleetkit import HEADER, T0, measurement_count, refusal
from tests.service.linekit import event

# The shared fixtures (pytest finds a fixture by its module's names).
engineer = fleetkit.engineer
keys = fleetkit.keys

# (a) a decimal comma whose fields still match the column count ----------------------------


@pytest.mark.parametrize(
    ("rows", "expected"),
    [
        # 2,45 split into door 2 and brake 45 — the brake cell left empty made the count match
        (
            "0117,2026-11-01T07:30:00Z,2.41,4.02\n0117,2026-11-03T07:30:00Z,2,45\n",
            "line 3, columns door_close_s and brake_release_s: 2 and 45",
        ),
        # the fraction of 2,05 is never how a number is written
        (
            "0117,2026-11-01T07:30:00Z,2,05\n",
            "line 2, columns door_close_s and brake_release_s: 2 and 05",
        ),
    ],
)
def test_decimal_comma_with_matching_field_count_is_refused(
    keys: dict, session: Session, rows: str, expected: str
) -> None:
    detail = refusal(session, HEADER + rows)
    assert expected in detail and "decimal comma" in detail, detail


def test_value_under_an_unnamed_column_is_refused(keys: dict, session: Session) -> None:
    # An exported header with a trailing separator: the fraction of 2,5 fell into column 4.
    detail = refusal(session, "car,taken_at,door_close_s,\n0117,2026-11-01T07:30:00Z,2,5\n")
    assert "line 2, column 4" in detail and "decimal comma" in detail, detail


def test_a_column_named_twice_is_refused(keys: dict, session: Session) -> None:
    """Only the second of two door_close_s cells was stored, silently (second trial)."""
    text = "car,taken_at,door_close_s,door_close_s\n0117,2026-11-10T08:00:00Z,3.1,3.3\n"
    assert "door_close_s more than once" in refusal(session, text)


def test_semicolon_separated_file_is_named(keys: dict, session: Session) -> None:
    detail = refusal(session, "car;taken_at;door_close_s\n0117;2026-11-01T07:30:00Z;2,5\n")
    assert "';'" in detail and "decimal" in detail, detail


def test_integers_stay_accepted_when_the_file_writes_no_decimals(
    keys: dict, session: Session
) -> None:
    text = HEADER + "0117,2026-11-01T07:30:00Z,2,4\n0118,2026-11-01T07:30:00Z,3,5\n"
    tests = parse_tests(io.StringIO(text), registered(session))
    assert [values for _, _, values in tests] == [
        {"door_close_s": 2.0, "brake_release_s": 4.0},
        {"door_close_s": 3.0, "brake_release_s": 5.0},
    ]


# (b) contradictory rows in one file --------------------------------------------------------


def test_contradictory_rows_are_refused_with_their_lines(keys: dict, session: Session) -> None:
    text = HEADER + (
        "0117,2026-11-01T07:30:00Z,2.41,4.02\n"
        "0118,2026-11-01T07:30:00Z,2.38,3.97\n"
        "0117,2026-11-01T07:30:00+00:00,2.51,4.02\n"
    )
    detail = refusal(session, text)
    assert "lines 2 and 4" in detail and "door_close_s" in detail, detail
    long = "car,taken_at,parameter,value\n" + (
        "0117,2026-11-01T07:30:00Z,door_close_s,2.4\n0117,2026-11-01T07:30:00Z,door_close_s,2.6\n"
    )
    assert "lines 2 and 3" in refusal(session, long)


def test_repeated_and_complementary_rows_are_one_test(keys: dict, session: Session) -> None:
    long = "car,taken_at,parameter,value\n" + (
        "0117,2026-11-01T07:30:00Z,door_close_s,2.4\n"
        "0117,2026-11-01T07:30:00Z,brake_release_s,4.1\n"
        "0117,2026-11-01T07:30:00Z,door_close_s,2.4\n"
    )
    tests = parse_tests(io.StringIO(long), registered(session))
    assert tests == [("0117", T0, {"door_close_s": 2.4, "brake_release_s": 4.1})]


# (c) the API: the same (car, taken_at) with another value ---------------------------------


def _measure(client: TestClient, headers: dict, values: dict, at: datetime = T0):
    body = {"taken_at": at.isoformat(), "values": values}
    return client.post("/api/v1/cars/0117/measurements", json=body, headers=headers)


def test_api_same_test_again_is_idempotent_and_a_changed_one_conflicts(
    keys: dict, client: TestClient, session: Session, engineer: dict
) -> None:
    assert _measure(client, engineer, {"door_close_s": 2.5}).status_code == 201
    again = _measure(client, engineer, {"door_close_s": 2.5})
    assert again.status_code == 200 and again.json()["measurements"] == 0, again.text
    # the same instant written with another offset is the same test
    other_offset = {"taken_at": "2026-11-01T09:30:00+02:00", "values": {"door_close_s": 2.5}}
    assert (
        client.post("/api/v1/cars/0117/measurements", json=other_offset, headers=engineer)
    ).status_code == 200
    changed = _measure(client, engineer, {"door_close_s": 2.6})
    assert changed.status_code == 409, changed.text
    assert changed.headers["content-type"] == "application/problem+json"
    assert "door_close_s" in changed.json()["detail"]
    assert measurement_count(session) == 1
    later = _measure(client, engineer, {"door_close_s": 2.6}, at=T0 + timedelta(days=1))
    assert later.status_code == 201


# (d) measurement events with refused values -----------------------------------------------


def test_refused_event_values_answer_422_and_store_nothing(
    keys: dict, client: TestClient, session: Session
) -> None:
    body = event("m-1", "measurement", at=T0.isoformat(), car="0117", values={"door_close_s": 3e9})
    answer = client.post("/api/v1/events", json=body, headers=keys["D-bench"])
    assert answer.status_code == 422, answer.text
    assert answer.headers["content-type"] == "application/problem+json"
    assert "outside its plausible range" in answer.json()["detail"]
    misspelt = event("m-2", "measurement", car="0117", values={"door_closse_s": 2.4})
    refused = client.post("/api/v1/events", json=misspelt, headers=keys["D-bench"])
    assert refused.status_code == 422 and "did you mean 'door_close_s'" in refused.text
    assert session.scalars(select(RawEvent).where(RawEvent.kind == "measurement")).all() == []
    assert measurement_count(session) == 0
    # in a batch the refused item is rejected with the reason, the good one stored
    good = event("m-3", "measurement", car="0117", values={"door_close_s": 2.4})
    batch = client.post("/api/v1/events", json={"events": [body, good]}, headers=keys["D-bench"])
    assert batch.status_code in (200, 207), batch.text
    first, second = batch.json()["results"]
    assert first["status"] == "rejected" and "plausible" in first["error"]["detail"]
    assert second["status"] == "created"
    assert measurement_count(session) == 1


def test_an_event_never_rewrites_a_stored_test(
    keys: dict, client: TestClient, session: Session
) -> None:
    """A ``measurement`` event with other values at a stored test's time was stored beside it
    (found by the second independent trial); the same rule as the API: 409, nothing stored,
    and the very same test again stores nothing twice."""
    first = event("t-1", "measurement", at=T0.isoformat(), car="0117", values={"door_close_s": 3.1})
    assert client.post("/api/v1/events", json=first, headers=keys["D-bench"]).status_code == 201
    other = {**first, "event_id": "t-2", "values": {"door_close_s": 3.45}}
    answer = client.post("/api/v1/events", json=other, headers=keys["D-bench"])
    assert answer.status_code == 409, answer.text
    assert "already has a test" in answer.json()["detail"]
    again = {**first, "event_id": "t-3"}
    assert client.post("/api/v1/events", json=again, headers=keys["D-bench"]).status_code == 201
    assert measurement_count(session) == 1
    batch = {"events": [{**other, "event_id": "t-4"}, {**first, "event_id": "t-5"}]}
    results = client.post("/api/v1/events", json=batch, headers=keys["D-bench"]).json()["results"]
    assert [r["status"] for r in results] == ["rejected", "created"]
    assert results[0]["error"]["status"] == 409
    assert measurement_count(session) == 1


# (e) an inverted plausible range ----------------------------------------------------------


@pytest.mark.parametrize(
    "limits",
    [
        {"plausible_lower": 5.0, "plausible_upper": 1.0},
        {"plausible_lower": 8.0},  # above the default upper limit (7.4 for this band)
        {"plausible_upper": -3.0},  # below the default lower limit (-2.6)
    ],
)
def test_inverted_plausible_range_is_refused(
    keys: dict, client: TestClient, engineer: dict, limits: dict
) -> None:
    band = {"name": "door_close_s", "nominal": 2.4, "tolerance": 0.5, "unit": "s", **limits}
    put = client.put("/api/v1/maintenance/parameters/door_close_s", json=band, headers=engineer)
    assert put.status_code == 422, put.text
    assert "plausible" in put.json()["detail"]
    created = client.post(
        "/api/v1/maintenance/parameters", json={**band, "name": "door_open_s"}, headers=engineer
    )
    assert created.status_code == 422, created.text


# (f) a car already out of tolerance never ranks below cars inside -------------------------


def _forecast(car: str, risk: float | None, status: str = "ok", **payload: object) -> Forecast:
    return Forecast(car_id=car, status=status, risk=risk, payload=dict(payload))


def test_out_of_tolerance_car_ranks_first_and_is_never_serviceable() -> None:
    inside = _forecast("0201", 0.3, out_of_band_now=False)
    # uncalibrated index band: the index looks fine, a parameter is already out of tolerance
    out = _forecast("0202", 0.0, out_of_band_now=False, out_of_tolerance_now=["door_close_s"])
    failed = _forecast("0203", None, status="failed", out_of_tolerance_now=["door_close_s"])
    ranked = sorted([inside, out, failed], key=lambda f: (views.rank_key(f), f.car_id))
    assert [f.car_id for f in ranked] == ["0202", "0203", "0201"]
    assert views.recommendation(out) == "plan_withdrawal"
    assert views.recommendation(failed) == "plan_withdrawal"


def test_forecast_row_names_parameters_already_out_of_tolerance(
    keys: dict, session: Session
) -> None:
    """Uncalibrated fleet (per-car weights): the latest test has door_close_s at 3.2 s, outside
    2.4 ± 0.5 s; the row says so whatever the index band, and the car is not serviceable."""
    bands = load_bands(session)
    rng = np.random.default_rng(3)
    n = 40
    values = np.column_stack(
        [4.0 + 0.05 * rng.standard_normal(n), 2.4 + 0.02 * rng.standard_normal(n)]
    )
    values[-1, 1] = 3.2
    epoch = T0.timestamp() + 86400.0 * np.arange(n)
    history = CarHistory("0117", epoch, ("brake_release_s", "door_close_s"), values)
    fleet = FleetIndex((), None, (-np.inf, np.inf), "uncalibrated")
    row = forecast_row(history, bands, fleet, ForecastOptions(), T0)
    payload = row["payload"]
    assert payload["out_of_tolerance_now"] == ["door_close_s"], payload.get("reasons")
    assert payload["out_of_band_now"] is True
    assert "door_close_s" in payload["reasons"][0] and "out of tolerance" in payload["reasons"][0]
    forecast = Forecast(car_id="0117", status=row["status"], risk=row["risk"], payload=payload)
    assert views.recommendation(forecast) == "plan_withdrawal"
