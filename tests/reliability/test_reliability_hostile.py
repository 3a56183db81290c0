"""Hostile input: every attack gets a 4xx problem+json and changes nothing (rows and files)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import func, select, text
from sqlalchemy.orm import Session

from core.models import Car, Device, Section, Station
from core.settings import get_settings
from ingest.models import RawEvent, Snapshot
from tests.conftest import ADMIN
from tests.reliability.hostile import (
    EVENT,
    EVENT_ATTACKS,
    HOSTILE_IDS,
    SETUP_BODIES,
    SNAPSHOT_ATTACKS,
    small_image,
)
from tests.service.linekit import build_line

HUGE = "99999999999999999999999"


def _cases(names: list[str]) -> list[Any]:
    return list(names)


TABLES = (RawEvent, Snapshot, Station, Section, Device, Car)


def _footprint(session: Session) -> dict[str, Any]:
    counts = {m.__tablename__: session.scalar(select(func.count()).select_from(m)) for m in TABLES}
    images = get_settings().image_dir
    files = sorted(str(p) for p in images.rglob("*")) if images.exists() else []
    return {**counts, "files": files}


@pytest.fixture
def line(client: TestClient) -> dict[str, dict[str, str]]:
    return build_line(client)


def _assert_rejected(response: Any, expected: int) -> None:
    assert response.status_code == expected, response.text[:500]
    assert response.headers["content-type"].startswith("application/problem+json")
    body = response.json()
    assert body["status"] == expected and body["title"] and body["detail"]


@pytest.mark.parametrize("name", list(EVENT_ATTACKS))
def test_hostile_event_bodies(
    name: str, client: TestClient, session: Session, line: dict[str, dict[str, str]]
) -> None:
    build, expected = EVENT_ATTACKS[name]
    before = _footprint(session)
    kwargs = build()
    kwargs["headers"] = {**kwargs.get("headers", {}), **line["B-ac"]}
    response = client.post("/api/v1/events", **kwargs)
    _assert_rejected(response, expected)
    assert _footprint(session) == before


@pytest.mark.parametrize("name", _cases(list(SNAPSHOT_ATTACKS)))
def test_hostile_snapshots(
    name: str, client: TestClient, session: Session, line: dict[str, dict[str, str]]
) -> None:
    build, expected = SNAPSHOT_ATTACKS[name]
    before = _footprint(session)
    response = client.post("/api/v1/snapshots", headers=line["B-cam"], **build())
    assert 400 <= response.status_code < 500, response.text[:300]
    _assert_rejected(response, expected)
    assert _footprint(session) == before


@pytest.mark.parametrize("path", list(SETUP_BODIES))
def test_hostile_setup_ids(
    path: str, client: TestClient, session: Session, line: dict[str, dict[str, str]]
) -> None:
    before = _footprint(session)
    for ident in HOSTILE_IDS:
        response = client.post(f"/api/v1{path}", json=SETUP_BODIES[path](ident), headers=ADMIN)
        _assert_rejected(response, 422)
    assert _footprint(session) == before


@pytest.mark.parametrize(
    "path",
    _cases(
        [
            "/api/v1/stations/..%2F..%2Fetc%2Fpasswd",
            "/api/v1/devices/A'%20OR%20'1'='1",
            "/api/v1/cars/%00",
            "/api/v1/sections/AB%3BDROP%20TABLE%20sections",
            "/api/v1/runs/1%20OR%201=1",
            f"/api/v1/runs/{HUGE}",
            f"/api/v1/snapshots/{HUGE}",
            f"/api/v1/snapshots/{HUGE}/meta",
            f"/api/v1/audit?run={HUGE}",
            "/api/v1/runs?limit=100000000000000000000",
            f"/api/v1/runs?cursor=-{HUGE}",
            "/api/v1/snapshots/-1",
            "/api/v1/snapshots/1/..%2F..%2Fmeta",
        ]
    ),
)
def test_hostile_path_parameters(
    path: str,
    client: TestClient,
    session: Session,
    line: dict[str, dict[str, str]],
    request: pytest.FixtureRequest,
) -> None:
    before = _footprint(session)
    response = client.get(path, headers=ADMIN)
    assert response.status_code in (200, 404, 422), response.text[:300]
    assert _footprint(session) == before
    assert session.execute(text("SELECT count(*) FROM sections")).scalar() == 2


def test_sql_and_path_fragments_in_event_ids_are_only_data(
    client: TestClient, session: Session, line: dict[str, dict[str, str]]
) -> None:
    """Printable event ids are opaque keys: stored literally once, never a path or SQL."""
    before = _footprint(session)
    ids = [
        "x'OR'1'='1;DROP/**/TABLE/**/raw_events;--",
        "../../../../etc/passwd",
        "..\\..\\boot.ini",
    ]
    for event_id in ids:
        response = client.post(
            "/api/v1/events", json={**EVENT, "event_id": event_id}, headers=line["B-ac"]
        )
        assert response.status_code == 201, response.text
    stored = session.scalars(select(RawEvent.event_id).where(RawEvent.device_id == "B-ac")).all()
    assert sorted(stored) == sorted(ids)
    form = {"event_id": "../../../escape", "occurred_at": "2026-11-23T10:00:00Z", "section": "AB"}
    files = {"image": ("../../../escape.jpg", small_image("JPEG"), "image/jpeg")}
    response = client.post("/api/v1/snapshots", data=form, files=files, headers=line["B-cam"])
    assert response.status_code == 201, response.text
    images = get_settings().image_dir.resolve()
    new = set(_footprint(session)["files"]) - set(before["files"])
    assert new and all(Path(f).resolve().is_relative_to(images) for f in new)
    assert not any("escape" in f for f in new)


def test_header_injection_and_oversized_credentials(
    client: TestClient, session: Session, line: dict[str, dict[str, str]]
) -> None:
    before = _footprint(session)
    hostile = [
        {"X-Device-Key": "k" * 60_000},
        {"X-Device-Key": "' OR '1'='1"},
        {"Authorization": "Bearer ' OR 1=1 --"},
        {"Authorization": "Bearer " + "t" * 60_000},
        {"Authorization": "Basic YWRtaW46YWRtaW4="},
        {"X-Device-Key": line["B-ac"]["X-Device-Key"] + "\t"},
    ]
    for headers in hostile:
        response = client.post("/api/v1/events", json=EVENT, headers=headers)
        _assert_rejected(response, 401)
        assert "x-injected" not in response.headers
    assert _footprint(session) == before
