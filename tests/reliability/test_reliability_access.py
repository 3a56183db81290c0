"""Access: every endpoint × role against protocol.md; secrets stored only hashed, never logged.

The matrix is a table: a new endpoint is one line in ``ENDPOINTS``; a route of the app missing
from the table fails ``test_every_route_is_in_the_matrix``.
"""

from __future__ import annotations

import hashlib
import io
import logging
from itertools import count
from typing import Any

import pytest
from fastapi.testclient import TestClient
from PIL import Image
from sqlalchemy import text
from sqlalchemy.orm import Session

from service.models import metadata
from service.setup.service import create_user
from tests.conftest import ADMIN, ADMIN_TOKEN
from tests.reliability.matrix import DEVICE_ROLES, ENDPOINTS, KIND_OF, ROLES
from tests.service.linekit import build_line, register_bands

PARAMS = {
    "station_id": "A",
    "section_id": "AB",
    "device_id": "A-cam",
    "car_id": "0117",
    "run_id": "1",
    "snapshot_id": "1",
    "name": "door_close_s",
    "train": "2041",
}
_serial = count()


def _png() -> bytes:
    buffer = io.BytesIO()
    Image.new("RGB", (32, 32), (10, 10, 10)).save(buffer, format="PNG")
    return buffer.getvalue()


def _request(client: TestClient, method: str, path: str, headers: dict[str, str]) -> Any:
    # Credential changes act on a device and a person no role uses (404 for the admin), so
    # that one role's rotation cannot lock the next role out.
    changes_credentials = path.endswith(("/key", "/decommission", "/rotate", "/revoke"))
    params = {**PARAMS, "device_id": "spare-device"} if changes_credentials else PARAMS
    url = path.format(**params)
    n = next(_serial)
    at = "2026-11-23T10:00:00Z"
    if path.endswith("/events") and method == "POST":
        body = {"event_id": f"acc-{n}", "occurred_at": at, "kind": "heartbeat"}
        return client.post(url, json=body, headers=headers)
    if path.endswith("/snapshots"):
        form = {"event_id": f"acc-{n}", "occurred_at": at, "section": "AB"}
        files = {"image": ("t.png", _png(), "image/png")}
        return client.post(url, data=form, files=files, headers=headers)
    if method == "GET":
        return client.get(url, headers=headers)
    return client.request(method, url, json={}, headers=headers)


@pytest.fixture
def credentials(client: TestClient, session: Session) -> dict[str, dict[str, str]]:
    keys = build_line(client)
    register_bands(client)  # a measurement's values must name registered parameters
    people = {
        role: create_user(session, f"acc-{role}", role) for role in ("dispatcher", "engineer")
    }
    session.commit()  # a refused request rolls the session back; the people must survive it
    creds = {"anonymous": {}, "admin": ADMIN}
    creds |= {role: {"Authorization": f"Bearer {token}"} for role, token in people.items()}
    creds |= {role: keys[ident] for role, ident in DEVICE_ROLES.items()}
    creds["arrival interlocking"] = keys["B-ilk"]  # DEVICE_ROLES has A's; arrivals come from B
    return creds


def _routes(client: TestClient) -> set[tuple[str, str]]:
    """Every documented operation (the OpenAPI document is what integrators script against)."""
    paths = client.get("/openapi.json").json()["paths"]
    return {(method.upper(), path) for path, item in paths.items() for method in item}


@pytest.fixture(scope="module")
def served() -> set[tuple[str, str]]:
    """The documented operations, rendered once: every test's app comes from the same
    ``create_app()``, and rendering its OpenAPI document takes ~0.5 s per app."""
    from service.app import create_app

    with TestClient(create_app()) as client:
        return _routes(client)


def test_every_route_is_in_the_matrix(client: TestClient) -> None:
    missing = _routes(client) - {(m, p) for m, p, _ in ENDPOINTS}
    lines = [f'    ("{m}", "{p}", READERS),' for m, p in sorted(missing)]
    assert not missing, "add these routes to ENDPOINTS with their roles:\n" + "\n".join(lines)


@pytest.mark.parametrize(
    ("method", "path", "allowed"), ENDPOINTS, ids=[f"{m} {p}" for m, p, _ in ENDPOINTS]
)
def test_access_matrix(
    method: str,
    path: str,
    allowed: frozenset[str],
    client: TestClient,
    credentials: dict[str, dict[str, str]],
    caplog: pytest.LogCaptureFixture,
    served: set[tuple[str, str]],
) -> None:
    if (method, path) not in served:
        pytest.skip(f"{method} {path} is not served yet")
    caplog.set_level(logging.DEBUG)
    wrong: list[str] = []
    for role in ROLES:
        status = _request(client, method, path, credentials[role]).status_code
        if role in allowed:
            ok = status not in (401, 403) and status < 500
        else:
            ok = status == (401 if role == "anonymous" else 403)
        if not ok:
            wrong.append(f"{role}: {status}")
    assert not wrong, f"{method} {path} (may: {sorted(allowed)}): {wrong}"
    secrets = [ADMIN_TOKEN, *(v.split()[-1] for c in credentials.values() for v in c.values())]
    assert not [s for s in secrets if s in caplog.text], "a credential appeared in the log"


AT = "2026-11-23T10:00:00Z"
# protocol.md, "Device events": kind → example fields and the device kinds that may send it.
PROTOCOL_EVENTS: dict[str, tuple[dict[str, Any], frozenset[str]]] = {
    "train_departed": ({"section": "AB", "train": "2041"}, frozenset({"interlocking"})),
    "train_arrived": ({"section": "AB", "train": "2041"}, frozenset({"interlocking"})),
    "axle_count": ({"section": "AB", "axles": 16}, frozenset({"axle_counter"})),
    "ir_id": ({"section": "AB", "reads": [117, 117]}, frozenset({"ir_reader"})),
    "ir_pulses": (
        {
            "section": "AB",
            "query_period_us": 1000,
            "reflection_window_us": 200,
            "reply_times_us": [262.5, 118262.0],
        },
        frozenset({"ir_reader"}),
    ),
    "ir_manchester": (
        {"section": "AB", "samples_per_bit": 8, "samples": [1, 0] * 8},
        frozenset({"ir_reader"}),
    ),
    "wheel_marks": (
        {"section": "AB", "direction": 1, "baseline": [2050] * 6, "axles": [[2170, 1931] * 4] * 4},
        frozenset({"wheel_mark_reader"}),
    ),
    "wheel_marks_written": (
        {"car": "0117", "code": 117, "detections": ["W1", "W2"] * 4},
        frozenset({"marking_station"}),
    ),
    "measurement": (
        {"car": "0117", "values": {"door_close_s": 2.4}},
        frozenset({"test_bench", "onboard_unit"}),
    ),
    "motion_sample": ({"train": "2041", "t": 1.5, "accel_mps2": -0.4}, frozenset({"onboard_unit"})),
    "eot_status": (
        {"section": "AB", "unit_address": 39572, "pressure_psig": 89},
        frozenset({"eot_receiver"}),
    ),
    "heartbeat": ({}, frozenset(KIND_OF.values())),
}


@pytest.mark.parametrize("kind", list(PROTOCOL_EVENTS))
def test_device_kinds_send_only_their_events(
    kind: str, client: TestClient, credentials: dict[str, dict[str, str]]
) -> None:
    fields, senders = PROTOCOL_EVENTS[kind]
    wrong = []
    for role in DEVICE_ROLES:
        device_kind = role.split(":")[1]
        body = {"event_id": f"k-{next(_serial)}", "occurred_at": AT, "kind": kind, **fields}
        status = client.post("/api/v1/events", json=body, headers=credentials[role]).status_code
        if status != (201 if device_kind in senders else 403):
            wrong.append(f"{device_kind}: {status}")
    assert not wrong, f"{kind} (sent by {sorted(senders)}): {wrong}"


def test_keys_and_tokens_are_stored_only_hashed(
    client: TestClient, session: Session, credentials: dict[str, dict[str, str]]
) -> None:
    secrets = [
        v.split()[-1] for role, c in credentials.items() if role != "admin" for v in c.values()
    ]
    assert len(secrets) == len(credentials) - 2 == len(ROLES) - 1
    hashes = {row[0] for row in session.execute(text("SELECT key_hash FROM devices"))}
    hashes |= {row[0] for row in session.execute(text("SELECT token_hash FROM users"))}
    assert {hashlib.sha256(s.encode()).hexdigest() for s in secrets} <= hashes
    for table in metadata.sorted_tables:
        dump = " ".join(map(str, session.execute(table.select()).all()))
        leaked = [s for s in [*secrets, ADMIN_TOKEN] if s in dump]
        assert not leaked, f"a plaintext credential is stored in {table.name}"


def test_review_screen_people_read_only_dispatchers_decide(
    client: TestClient, credentials: dict[str, dict[str, str]], session: Session
) -> None:
    assert client.get("/review", follow_redirects=False).headers["location"] == "/review/login"
    for token in (credentials["device:camera"]["X-Device-Key"], "not-a-token", "' OR 1=1 --"):
        response = client.post("/review/login", data={"token": token}, follow_redirects=False)
        assert response.status_code == 401
        assert "set-cookie" not in response.headers
    run = _arrived_run(client, credentials)
    decision = {"action": "keep_blocked", "reason": "forged"}
    for role in ("anonymous", "engineer", "dispatcher"):
        client.cookies.clear()
        if role != "anonymous":
            token = credentials[role]["Authorization"].split()[-1]
            login = client.post("/review/login", data={"token": token}, follow_redirects=False)
            assert login.status_code == 303
            cookie = login.headers["set-cookie"].lower()
            assert "httponly" in cookie and "samesite=strict" in cookie
        path = f"/review/runs/{run}/decision"
        response = client.post(path, data=decision, follow_redirects=False)
        assert response.status_code in (303, 401, 403)
        audits = session.execute(text("SELECT actor_role FROM audit_records")).scalars().all()
        assert audits == (["dispatcher"] if role == "dispatcher" else []), (role, audits)


def _arrived_run(client: TestClient, credentials: dict[str, dict[str, str]]) -> int:
    base = {"section": "AB", "train": "2041"}
    departed = {"event_id": "rv-1", "occurred_at": AT, "kind": "train_departed", **base}
    response = client.post(
        "/api/v1/events", json=departed, headers=credentials["device:interlocking"]
    )
    assert response.status_code == 201, response.text
    arrived = {
        **departed,
        "event_id": "rv-2",
        "kind": "train_arrived",
        "occurred_at": "2026-11-23T10:40:00Z",
    }
    response_arrived = client.post(
        "/api/v1/events", json=arrived, headers=credentials["arrival interlocking"]
    )
    assert response_arrived.status_code == 201, response_arrived.text
    return int(response.json()["run"])
