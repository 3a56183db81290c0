"""Maintenance API: measurements (API and bench events), parameter bands, overrides, access."""

from __future__ import annotations

from datetime import UTC, datetime, timedelta

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import select
from sqlalchemy.orm import Session

from ingest.models import RawEvent
from service.fleet.models import MaintenanceOverride, Measurement, decode_readings
from service.fleet.service import measured_values
from service.replay import replay
from service.setup.service import create_user
from tests.conftest import ADMIN
from tests.service.linekit import build_line, event, register_bands

T0 = datetime(2026, 11, 1, 7, 30, tzinfo=UTC)
BAND = {"name": "door_close_s", "nominal": 2.4, "tolerance": 0.5, "unit": "s"}


@pytest.fixture
def keys(client: TestClient) -> dict[str, dict[str, str]]:
    keys = build_line(client)
    register_bands(client)
    return keys


def _person(session: Session, name: str, role: str) -> dict[str, str]:
    token = create_user(session, name, role)
    session.commit()
    return {"Authorization": f"Bearer {token}"}


@pytest.fixture
def engineer(session: Session) -> dict[str, str]:
    return _person(session, "iryna", "engineer")


@pytest.fixture
def dispatcher(session: Session) -> dict[str, str]:
    return _person(session, "olena", "dispatcher")


def _measure(client: TestClient, headers: dict, car: str = "0117", **body: object):
    payload = {"taken_at": T0.isoformat(), "values": {"door_close_s": 2.5}, **body}
    return client.post(f"/api/v1/cars/{car}/measurements", json=payload, headers=headers)


def test_engineer_posts_measurements(
    keys: dict, client: TestClient, session: Session, engineer: dict
) -> None:
    response = _measure(client, engineer, values={"door_close_s": 2.5, "brake_release_s": 4.1})
    assert response.status_code == 201, response.text
    assert response.json()["measurements"] == 2
    # one row per test, its values in the layout's (sorted) parameter order
    (row,) = session.scalars(select(Measurement).where(Measurement.car_id == "0117")).all()
    assert decode_readings(row.readings) == [4.1, 2.5] and row.source == "api"
    assert measured_values(session, row) == {"door_close_s": 2.5, "brake_release_s": 4.1}
    assert row.taken_at == T0 and row.raw_event_id is None


def test_measurement_access_and_validation(
    keys: dict, client: TestClient, engineer: dict, dispatcher: dict
) -> None:
    assert _measure(client, {}).status_code == 401
    assert _measure(client, {"Authorization": "Bearer nope"}).status_code == 401
    assert _measure(client, dispatcher).status_code == 403
    assert _measure(client, keys["D-bench"]).status_code == 403  # devices post events instead
    missing = _measure(client, engineer, car="9999")
    assert missing.status_code == 404 and "9999" in missing.json()["detail"]
    naive = _measure(client, engineer, taken_at="2026-11-01T07:30:00")
    assert naive.status_code == 422
    assert naive.headers["content-type"] == "application/problem+json"
    assert _measure(client, engineer, values={}).status_code == 422
    assert _measure(client, engineer, values={"door_close_s": "fast"}).status_code == 422
    assert _measure(client, engineer, comment="extra").status_code == 422


def test_bench_measurement_event_is_stored_with_its_raw_event(
    keys: dict, client: TestClient, session: Session
) -> None:
    body = event("D-bench-3310", "measurement", car="0117", values={"door_close_s": 2.6})
    response = client.post("/api/v1/events", json=body, headers=keys["D-bench"])
    assert response.status_code == 201, response.text
    assert response.json()["measurements"] == 1
    raw = session.scalar(select(RawEvent).where(RawEvent.event_id == "D-bench-3310"))
    row = session.scalar(select(Measurement).where(Measurement.raw_event_id == raw.id))
    assert (row.car_id, measured_values(session, row), row.source) == (
        "0117",
        {"door_close_s": 2.6},
        "event",
    )
    again = client.post("/api/v1/events", json=body, headers=keys["D-bench"])
    assert again.status_code == 200  # a retry stores nothing twice
    assert len(session.scalars(select(Measurement)).all()) == 1


def test_replay_rebuilds_event_tests_and_keeps_the_others(
    keys: dict, client: TestClient, session: Session, engineer: dict
) -> None:
    body = event("D-bench-3312", "measurement", car="0117", values={"door_close_s": 2.7})
    assert client.post("/api/v1/events", json=body, headers=keys["D-bench"]).status_code == 201
    assert _measure(client, engineer, values={"brake_release_s": 4.3}).status_code == 201
    replay(session)
    rows = session.scalars(select(Measurement).order_by(Measurement.source)).all()
    assert [(r.source, measured_values(session, r)) for r in rows] == [
        ("api", {"brake_release_s": 4.3}),
        ("event", {"door_close_s": 2.7}),
    ]
    assert rows[1].raw_event_id is not None


def test_measurement_event_for_unknown_car_warns_and_keeps_the_raw_event(
    keys: dict, client: TestClient, session: Session
) -> None:
    body = event("D-bench-3311", "measurement", car="7777", values={"door_close_s": 2.6})
    response = client.post("/api/v1/events", json=body, headers=keys["D-bench"])
    assert response.status_code == 201, response.text
    assert "7777" in response.json()["warning"] and response.json()["measurements"] == 0
    raw = session.scalar(select(RawEvent).where(RawEvent.event_id == "D-bench-3311"))
    assert raw is not None and raw.derive_error is None
    assert session.scalars(select(Measurement)).all() == []
    camera = event("A-cam-1", "measurement", car="0117", values={"door_close_s": 2.6})
    assert client.post("/api/v1/events", json=camera, headers=keys["A-cam"]).status_code == 403


def test_registering_a_car_derives_the_measurements_that_waited_for_it(
    keys: dict, client: TestClient, session: Session
) -> None:
    """The warning promises the stored event is used once the car exists: registering the car
    derives its waiting measurement events (in their order), not only a full replay does."""
    for n, value in ((1, 2.6), (2, 2.7)):
        body = event(f"D-bench-34{n}", "measurement", car="7778", values={"door_close_s": value})
        body["occurred_at"] = f"2026-11-01T07:3{n}:00Z"
        assert client.post("/api/v1/events", json=body, headers=keys["D-bench"]).status_code == 201
    car = {"id": "7778", "axles": 4}
    created = client.post("/api/v1/cars", json=car, headers=ADMIN)
    assert created.status_code == 201, created.text
    rows = session.scalars(
        select(Measurement).where(Measurement.car_id == "7778").order_by(Measurement.taken_at)
    ).all()
    assert [measured_values(session, r)["door_close_s"] for r in rows] == [2.6, 2.7]
    assert all(r.raw_event_id is not None and r.source == "event" for r in rows)
    replay(session)  # live and replay agree
    again = session.scalars(select(Measurement).where(Measurement.car_id == "7778")).all()
    assert sorted(measured_values(session, r)["door_close_s"] for r in again) == [2.6, 2.7]


def test_parameters_and_bands(client: TestClient, engineer: dict, dispatcher: dict) -> None:
    created = client.post("/api/v1/maintenance/parameters", json=BAND, headers=engineer)
    assert created.status_code == 201, created.text
    assert created.json()["lower"] == pytest.approx(1.9)
    assert created.json()["upper"] == pytest.approx(2.9)
    listed = client.get("/api/v1/maintenance/parameters", headers=dispatcher).json()
    assert [p["name"] for p in listed] == ["door_close_s"]
    again = client.post("/api/v1/maintenance/parameters", json=BAND, headers=ADMIN)
    assert again.status_code == 409
    wider = {**BAND, "tolerance": 0.6}
    updated = client.put("/api/v1/maintenance/parameters/door_close_s", json=wider, headers=ADMIN)
    assert updated.status_code == 200 and updated.json()["upper"] == pytest.approx(3.0)
    other = {**BAND, "name": "brake_release_s"}
    assert (
        client.post("/api/v1/maintenance/parameters", json=other, headers=dispatcher).status_code
        == 403
    )
    assert client.get("/api/v1/maintenance/parameters").status_code == 401
    for bad in ({**other, "tolerance": 0}, {**other, "tolerance": -1}, {"name": "x"}):
        assert (
            client.post("/api/v1/maintenance/parameters", json=bad, headers=ADMIN).status_code
            == 422
        )
    absent = client.put("/api/v1/maintenance/parameters/nothing", json=other, headers=ADMIN)
    assert absent.status_code == 404


def test_not_enough_history_is_reported_not_raised(
    keys: dict, client: TestClient, engineer: dict
) -> None:
    client.post("/api/v1/maintenance/parameters", json=BAND, headers=engineer)
    assert client.get("/api/v1/cars/0117/forecast", headers=engineer).status_code == 404
    for day in range(3):
        taken = (T0 + timedelta(days=day)).isoformat()
        assert _measure(client, engineer, taken_at=taken).status_code == 201
    run = client.post("/api/v1/maintenance/forecasts", headers=engineer)
    assert run.status_code == 201, run.text
    assert run.json()["statuses"] == {"not_enough_history": 4}
    body = client.get("/api/v1/cars/0117/forecast", headers=engineer).json()
    assert body["status"] == "not_enough_history" and body["risk"] is None
    assert "not enough history" in body["reasons"][0]
    assert body["recommendation"] == "unknown" and body["forecast"] is None
    bare = client.get("/api/v1/cars/0118/forecast", headers=engineer).json()
    assert bare["reasons"] == ["no measurements of parameters with a tolerance band"]
    png = client.get("/api/v1/cars/0117/forecast.png", headers=engineer)
    assert png.status_code == 200 and png.content[:4] == b"\x89PNG"
    assert client.get("/api/v1/cars/9999/forecast", headers=engineer).status_code == 404


def test_forecast_run_access_and_options(keys: dict, client: TestClient, dispatcher: dict) -> None:
    assert client.post("/api/v1/maintenance/forecasts").status_code == 401
    assert client.post("/api/v1/maintenance/forecasts", headers=dispatcher).status_code == 403
    for bad in ({"method": "magic"}, {"horizon": 0}, {"order": 99}, {"window": 3}):
        response = client.post("/api/v1/maintenance/forecasts", json=bad, headers=ADMIN)
        assert response.status_code == 422, bad
    # fisher separates serviceable from faulty tests: there are none stored here
    fisher = client.post("/api/v1/maintenance/forecasts", json={"method": "fisher"}, headers=ADMIN)
    assert fisher.status_code == 422 and "fisher" in fisher.json()["detail"]
    assert client.get("/api/v1/maintenance/fleet", headers=dispatcher).json() == {
        "computed_at": None,
        "cars": [],
        "withdrawn": [],
    }


def test_engineer_override_is_audited_and_shown(
    keys: dict, client: TestClient, session: Session, engineer: dict, dispatcher: dict
) -> None:
    client.post("/api/v1/maintenance/forecasts", headers=ADMIN)
    path = "/api/v1/cars/0118/maintenance-decision"
    for bad in ({"action": "keep_in_service"}, {"action": "keep_in_service", "reason": "  ok "},
                {"action": "scrap", "reason": "worn out"}):  # fmt: skip
        assert client.post(path, json=bad, headers=engineer).status_code == 422
    keep = {"action": "keep_in_service", "reason": "bench re-test passed after valve swap"}
    assert client.post(path, json=keep, headers=dispatcher).status_code == 403
    assert client.post(path, json=keep).status_code == 401
    assert (
        client.post(
            "/api/v1/cars/9999/maintenance-decision", json=keep, headers=engineer
        ).status_code
        == 404
    )
    first = client.post(path, json=keep, headers=engineer)
    assert first.status_code == 201, first.text
    assert first.json()["actor"] == "iryna" and first.json()["action"] == "keep_in_service"
    withdraw = {"action": "withdraw_now", "reason": "door actuator leaking"}
    assert client.post(path, json=withdraw, headers=ADMIN).status_code == 201
    body = client.get("/api/v1/cars/0118/forecast", headers=dispatcher).json()
    assert [o["action"] for o in body["overrides"]] == ["withdraw_now", "keep_in_service"]
    assert body["override"]["actor"] == "admin" and body["decision"] == "withdraw_now"
    fleet = client.get("/api/v1/maintenance/fleet", headers=dispatcher).json()
    assert "0118" not in [c["car"] for c in fleet["cars"]]  # withdrawn cars leave the ranking
    car = next(c for c in fleet["withdrawn"] if c["car"] == "0118")
    assert car["override"]["reason"] == "door actuator leaking"
    assert car["decision"] == "withdraw_now" and car["recommendation"] == "unknown"
    records = session.scalars(select(MaintenanceOverride)).all()
    assert len(records) == 2  # append-only: the first decision is still there


def test_the_same_value_rule_for_api_and_events(
    keys: dict, client: TestClient, session: Session, engineer: dict
) -> None:
    """An implausible or unregistered value is refused by the API and by events alike (422,
    nothing stored; tests/service/test_service_fleet_trial.py has the event cases)."""
    implausible = _measure(client, engineer, values={"door_close_s": 3e9})
    assert implausible.status_code == 422
    assert "outside its plausible range" in implausible.json()["detail"]
    misspelt = _measure(client, engineer, values={"door_closse_s": 2.4})
    assert misspelt.status_code == 422 and "did you mean 'door_close_s'" in misspelt.text
    body = event("m-1", "measurement", at=T0.isoformat(), car="0117", values={"door_close_s": 3e9})
    answer = client.post("/api/v1/events", json=body, headers=keys["D-bench"])
    assert answer.status_code == 422 and "outside its plausible range" in answer.text
    assert session.scalars(select(Measurement)).all() == []
    # The engineer narrows the plausible range: a value inside the default range is refused.
    band = {**BAND, "plausible_lower": 1.0, "plausible_upper": 4.0}
    assert (
        client.put(
            "/api/v1/maintenance/parameters/door_close_s", json=band, headers=engineer
        ).status_code
        == 200
    )
    assert _measure(client, engineer, values={"door_close_s": 5.5}).status_code == 422
    assert _measure(client, engineer, values={"door_close_s": 3.9}).status_code == 201
