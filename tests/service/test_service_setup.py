"""Setup API, roles and health."""

from __future__ import annotations

from fastapi.testclient import TestClient
from sqlalchemy import select
from sqlalchemy.orm import Session

from core.auth import hash_secret
from core.models import Device, User
from service.setup.service import create_user
from tests.conftest import ADMIN
from tests.service.linekit import build_line, post_ok


def test_health_and_readiness(client: TestClient) -> None:
    assert client.get("/healthz").json() == {"status": "ok"}
    ready = client.get("/readyz")
    assert ready.status_code == 200, ready.text
    assert ready.json()["status"] == "ready"


def test_setup_creates_line_and_lists_it(client: TestClient) -> None:
    build_line(client)
    stations = client.get("/api/v1/stations", headers=ADMIN).json()
    assert [s["id"] for s in stations] == ["A", "B", "C"]
    section = client.get("/api/v1/sections/AB", headers=ADMIN).json()
    assert section["state"] == "free" and section["run"] is None
    car = client.get("/api/v1/cars/0117", headers=ADMIN).json()
    assert car == {"id": "0117", "wheel_code": 117, "ir_number": 117, "axles": 4}
    assert client.get("/api/v1/cars/9999", headers=ADMIN).status_code == 404


def test_duplicate_ids_conflict_as_problem_json(client: TestClient) -> None:
    post_ok(client, "/api/v1/stations", {"id": "A", "name": "Anan'iv"})
    again = client.post("/api/v1/stations", json={"id": "A", "name": "Other"}, headers=ADMIN)
    assert again.status_code == 409
    assert again.headers["content-type"] == "application/problem+json"
    assert again.json()["status"] == 409 and "already exists" in again.json()["detail"]


def test_device_key_shown_once_and_stored_hashed(client: TestClient, session: Session) -> None:
    keys = build_line(client)
    key = keys["A-cam"]["X-Device-Key"]
    device = session.scalar(select(Device).where(Device.id == "A-cam"))
    assert device is not None and device.key_hash == hash_secret(key) and key not in device.key_hash
    listed = client.get("/api/v1/devices/A-cam", headers=ADMIN).json()
    assert "key" not in listed and "key_hash" not in listed


def test_section_needs_existing_distinct_stations(client: TestClient) -> None:
    post_ok(client, "/api/v1/stations", {"id": "A", "name": "A"})
    missing = client.post(
        "/api/v1/sections", json={"id": "AX", "from_station": "A", "to_station": "X"}, headers=ADMIN
    )
    assert missing.status_code == 422 and "X" in missing.json()["detail"]
    same = client.post(
        "/api/v1/sections", json={"id": "AA", "from_station": "A", "to_station": "A"}, headers=ADMIN
    )
    assert same.status_code == 422


def test_roles_401_and_403(client: TestClient, session: Session) -> None:
    keys = build_line(client)
    body = {"id": "Z", "name": "Zhmerynka"}
    assert client.post("/api/v1/stations", json=body).status_code == 401
    wrong = client.post("/api/v1/stations", json=body, headers={"Authorization": "Bearer nope"})
    assert wrong.status_code == 401 and wrong.headers["content-type"] == "application/problem+json"
    dispatcher = {"Authorization": f"Bearer {create_user(session, 'olena', 'dispatcher')}"}
    session.commit()
    assert client.post("/api/v1/stations", json=body, headers=dispatcher).status_code == 403
    assert client.get("/api/v1/stations", headers=dispatcher).status_code == 200
    assert client.get("/api/v1/stations", headers=keys["A-cam"]).status_code == 403
    assert client.get("/api/v1/stations").status_code == 401


def test_user_tokens_stored_hashed(session: Session) -> None:
    token = create_user(session, "ivan", "engineer")
    user = session.scalar(select(User).where(User.name == "ivan"))
    assert user is not None and user.role == "engineer" and user.token_hash == hash_secret(token)


STRONG = "h7Qm2-vXc9LpT4wZ_rB6nYk3sJd8FgA1"  # a generated-looking token (weak ones are refused)


def test_production_refuses_unsafe_defaults() -> None:
    import pytest
    from pydantic import ValidationError

    from core.settings import Settings

    with pytest.raises(ValidationError, match="DEPOT_ADMIN_TOKEN"):
        Settings(environment="production", admin_token="dev-admin-token")
    with pytest.raises(ValidationError, match="PostgreSQL"):
        Settings(environment="production", admin_token=STRONG)
    # found by the second trial: MySQL started and answered 500 on every request
    for other in ("mysql://u:p@127.0.0.1/x", "sqlite:///depot.db"):
        with pytest.raises(ValidationError, match="PostgreSQL"):
            Settings(environment="production", admin_token=STRONG, database_url=other)
    safe = Settings(
        environment="production", admin_token=STRONG, database_url="postgresql+psycopg://db/depot"
    )
    assert safe.resolved_database_url.startswith("postgresql")


def test_openapi_documents_the_event_schemas(client: TestClient) -> None:
    document = client.get("/openapi.json").json()
    schemas = document["components"]["schemas"]
    assert {"DeviceEvent", "EventBatch", "TrainArrived", "WheelMarks"} <= schemas.keys()
    body = document["paths"]["/api/v1/events"]["post"]["requestBody"]
    assert "DeviceEvent" in str(body)


def test_a_car_s_codes_are_numbers_within_the_fleet_s_range(client: TestClient) -> None:
    """An independent trial: ``POST /cars`` took wheel_code 300 (a wheel mark carries
    ``zones_per_axle`` = 8 bits in the duplicate layout: 0–255, identification.md §2) and "7"
    (text). Each is refused, 422 problem+json naming the field; 255 is accepted."""
    from identification.rules import RULES

    top = 2**RULES.zones_per_axle - 1
    for n, (field, value) in enumerate(
        [
            ("wheel_code", top + 1),
            ("wheel_code", -1),
            ("wheel_code", "7"),
            ("wheel_code", True),
            ("ir_number", "7"),
            ("axles", "4"),
        ]  # fmt: skip
    ):
        body = {"id": f"09{n}", field: value}
        answer = client.post("/api/v1/cars", json=body, headers=ADMIN)
        assert answer.status_code == 422, (field, value, answer.text)
        assert answer.headers["content-type"] == "application/problem+json"
        assert [e["loc"] for e in answer.json()["errors"]] == [["body", field]], answer.json()
    assert client.get("/api/v1/cars", headers=ADMIN).json() == []
    post_ok(client, "/api/v1/cars", {"id": "0255", "wheel_code": top, "ir_number": 7})
