"""Credential lifecycle: people's tokens and device keys rotated, revoked, expired, audited."""

from __future__ import annotations

import time
from datetime import timedelta

from fastapi.testclient import TestClient
from sqlalchemy import select
from sqlalchemy.orm import Session

from core.database import utcnow
from core.models import User
from tests.conftest import ADMIN
from tests.service.linekit import build_line, event

# A device key cache, where there is one, forgets a changed key within this bound (protocol.md).
KEY_CACHE_BOUND_S = 5.0


def _bearer(token: str) -> dict[str, str]:
    return {"Authorization": f"Bearer {token}"}


def _status_within(client: TestClient, headers: dict[str, str], want: int) -> int:
    """Post heartbeats until the answer is ``want`` or the cache bound has passed."""
    deadline = time.monotonic() + KEY_CACHE_BOUND_S + 1.0
    n = 0
    while True:
        n += 1
        body = event(f"hb-{time.monotonic_ns()}-{n}", "heartbeat", at=utcnow().isoformat())
        status = client.post("/api/v1/events", json=body, headers=headers).status_code
        if status == want or time.monotonic() > deadline:
            return status
        time.sleep(0.25)


def test_person_added_rotated_and_revoked_through_the_api(client: TestClient) -> None:
    added = client.post(
        "/api/v1/users", json={"name": "olena", "role": "dispatcher"}, headers=ADMIN
    )
    assert added.status_code == 201, added.text
    first = added.json()["token"]
    assert client.get("/api/v1/sections", headers=_bearer(first)).status_code == 200
    again = client.post("/api/v1/users", json={"name": "olena", "role": "engineer"}, headers=ADMIN)
    assert again.status_code == 409 and "rotate" in again.json()["detail"]

    rotated = client.post("/api/v1/users/olena/rotate", headers=ADMIN)
    assert rotated.status_code == 200
    second = rotated.json()["token"]
    assert second != first
    assert client.get("/api/v1/sections", headers=_bearer(first)).status_code == 401
    assert client.get("/api/v1/sections", headers=_bearer(second)).status_code == 200

    assert client.post("/api/v1/users/olena/revoke", headers=ADMIN).status_code == 200
    refused = client.get("/api/v1/sections", headers=_bearer(second))
    assert refused.status_code == 401
    assert refused.headers["content-type"].startswith("application/problem+json")
    assert client.post("/api/v1/users/olena/revoke", headers=ADMIN).status_code == 409
    assert client.post("/api/v1/users/olena/rotate", headers=ADMIN).status_code == 409

    people = client.get("/api/v1/users", headers=ADMIN).json()
    assert [(p["name"], p["revoked_at"] is not None) for p in people] == [("olena", True)]
    actions = [c["action"] for c in client.get("/api/v1/credential-changes", headers=ADMIN).json()]
    assert actions == ["user_revoked", "user_rotated", "user_added"]
    assert not any(first in str(c) or second in str(c) for c in people)


def test_an_expired_token_is_refused(client: TestClient, session: Session) -> None:
    body = {"name": "ivan", "role": "engineer", "expires_in_days": 1}
    token = client.post("/api/v1/users", json=body, headers=ADMIN).json()["token"]
    assert client.get("/api/v1/sections", headers=_bearer(token)).status_code == 200
    user = session.scalar(select(User).where(User.name == "ivan"))
    assert user is not None and user.expires_at is not None
    user.expires_at = utcnow() - timedelta(seconds=1)
    session.commit()
    assert client.get("/api/v1/sections", headers=_bearer(token)).status_code == 401


def test_only_the_admin_manages_credentials(client: TestClient) -> None:
    token = client.post(
        "/api/v1/users", json={"name": "olena", "role": "dispatcher"}, headers=ADMIN
    ).json()["token"]
    for method, path in (
        ("GET", "/api/v1/users"),
        ("POST", "/api/v1/users/olena/rotate"),
        ("POST", "/api/v1/devices/A-cam/key"),
        ("POST", "/api/v1/devices/A-cam/decommission"),
    ):
        assert client.request(method, path, headers=_bearer(token)).status_code == 403, path


def test_device_key_rotated_and_device_decommissioned(client: TestClient) -> None:
    keys = build_line(client)
    old = keys["A-ac"]
    assert _status_within(client, old, 201) == 201
    rotated = client.post("/api/v1/devices/A-ac/key", headers=ADMIN)
    assert rotated.status_code == 200
    new = {"X-Device-Key": rotated.json()["key"]}
    assert _status_within(client, new, 201) == 201
    assert _status_within(client, old, 401) == 401

    assert client.post("/api/v1/devices/A-ac/decommission", headers=ADMIN).status_code == 200
    assert _status_within(client, new, 401) == 401
    device = client.get("/api/v1/devices/A-ac", headers=ADMIN)
    assert device.status_code == 200 and device.json()["last_seen_at"] is not None  # history
    assert client.post("/api/v1/devices/A-ac/key", headers=ADMIN).status_code == 409
    assert client.post("/api/v1/devices/nope/decommission", headers=ADMIN).status_code == 404
    changes = client.get("/api/v1/credential-changes?subject=A-ac", headers=ADMIN).json()
    assert [c["action"] for c in changes] == [
        "device_decommissioned",
        "device_key_rotated",
        "device_registered",
    ]


def test_rotation_keeps_the_expiry_unless_a_new_one_is_given(
    client: TestClient, session: Session
) -> None:
    """Found by the independent trial: rotating turned a 1-day token into a permanent one."""
    body = {"name": "petro", "role": "engineer", "expires_in_days": 1}
    added = client.post("/api/v1/users", json=body, headers=ADMIN).json()
    rotated = client.post("/api/v1/users/petro/rotate", headers=ADMIN).json()
    assert rotated["expires_at"] == added["expires_at"] is not None
    longer = client.post(
        "/api/v1/users/petro/rotate", json={"expires_in_days": 30}, headers=ADMIN
    ).json()
    assert longer["expires_at"] > added["expires_at"]


def test_rotating_an_expired_token_needs_a_new_expiry(client: TestClient, session: Session) -> None:
    """Found by the second trial: the new token kept the past expiry, dead on arrival."""
    from datetime import timedelta

    from core.database import utcnow
    from core.models import User

    body = {"name": "taras", "role": "dispatcher", "expires_in_days": 1}
    assert client.post("/api/v1/users", json=body, headers=ADMIN).status_code == 201
    user = session.query(User).filter_by(name="taras").one()
    user.expires_at = utcnow() - timedelta(hours=1)
    session.commit()
    refused = client.post("/api/v1/users/taras/rotate", headers=ADMIN)
    assert refused.status_code == 422 and "expires_in_days" in refused.json()["detail"]
    renewed = client.post("/api/v1/users/taras/rotate", json={"expires_in_days": 7}, headers=ADMIN)
    assert renewed.status_code == 200, renewed.text
    token = renewed.json()["token"]
    assert (
        client.get("/api/v1/runs", headers={"Authorization": f"Bearer {token}"}).status_code == 200
    )
    changes = client.get("/api/v1/credential-changes?subject=taras", headers=ADMIN).json()
    assert changes[0]["action"] == "user_rotated" and "7 days" in changes[0]["detail"]


def test_registering_a_device_is_audited(client: TestClient) -> None:
    """Found by the independent trial: the key issued at registration left no audit record."""
    build_line(client)
    changes = client.get("/api/v1/credential-changes?subject=A-ac", headers=ADMIN).json()
    assert [c["action"] for c in changes] == ["device_registered"]
    assert changes[0]["actor"] == "admin" and changes[0]["subject_kind"] == "device"
    assert "axle_counter" in changes[0]["detail"] and "station A" in changes[0]["detail"]
    rotated = client.post("/api/v1/devices/A-ac/key", headers=ADMIN).json()["key"]
    every = client.get("/api/v1/credential-changes?subject=A-ac", headers=ADMIN).json()
    assert [c["action"] for c in every] == ["device_key_rotated", "device_registered"]
    assert not any(rotated in str(c) for c in every)  # the secret itself is never recorded


def test_one_name_rule_for_the_api_and_the_service(client: TestClient, session: Session) -> None:
    """Found by the independent trial: `depot user add` stored names the API refuses."""
    from core.errors import Unprocessable
    from service.setup.credentials import add_user

    # People's names may be in any alphabet (test_service_people.py); these are still refused.
    for bad in ("olena  petrenko", "-x", "", "a" * 65, "Олeна", "x;drop"):
        answer = client.post("/api/v1/users", json={"name": bad, "role": "engineer"}, headers=ADMIN)
        assert answer.status_code == 422, bad
        try:
            add_user(session, bad, "engineer", actor="test")
        except Unprocessable as exc:
            assert "name" in exc.detail
        else:
            raise AssertionError(f"the service accepted {bad!r}")
    assert add_user(session, "olena.p-2", "engineer", actor="test")[0].name == "olena.p-2"
