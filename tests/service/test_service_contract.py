"""The typed HTTP contract: every JSON answer documented, one instant format, finite bands."""

from __future__ import annotations

import re
from datetime import UTC, datetime, timedelta
from typing import Any

from fastapi.testclient import TestClient

from core.schemas import format_instant
from tests.conftest import ADMIN
from tests.service.linekit import build_line, event

INSTANT = re.compile(r"^\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d(\.\d{3})?Z$")
T0 = datetime(2026, 11, 1, 7, 30, tzinfo=UTC)


def _typed(schema: dict[str, Any]) -> bool:
    if "$ref" in schema or "anyOf" in schema:
        return True
    return schema.get("type") == "array" and _typed(schema.get("items", {}))


def test_every_json_success_answer_has_a_documented_schema(client: TestClient) -> None:
    untyped = []
    for path, operations in client.get("/openapi.json").json()["paths"].items():
        for method, operation in operations.items():
            for status, response in operation["responses"].items():
                schema = response.get("content", {}).get("application/json", {}).get("schema")
                if status.startswith("2") and schema is not None and not _typed(schema):
                    untyped.append(f"{method.upper()} {path} {status}")
    assert not untyped, untyped


def _instants(value: Any, key: str = "") -> list[tuple[str, str]]:
    if isinstance(value, dict):
        return [pair for k, v in value.items() for pair in _instants(v, k)]
    if isinstance(value, list):
        return [pair for v in value for pair in _instants(v, key)]
    is_time = isinstance(value, str) and (key.endswith("_at") or key.endswith("_since"))
    return [(key, value)] if is_time else []


def test_every_instant_is_utc_with_z(client: TestClient) -> None:
    keys = build_line(client)
    for n, (device, body) in enumerate(
        [
            ("A-ilk", {"kind": "train_departed", "section": "AB", "train": "2041"}),
            ("B-ilk", {"kind": "train_arrived", "section": "AB", "train": "2041"}),
        ]
    ):
        at = (T0 + timedelta(minutes=20 * n)).isoformat()  # written +00:00 by this "device"
        answer = client.post(
            "/api/v1/events", json=event(f"c-{n}", at=at, **body), headers=keys[device]
        )
        assert answer.status_code == 201, answer.text
    answers = [
        client.get(path, headers=ADMIN).json()
        for path in ("/api/v1/sections", "/api/v1/runs", "/api/v1/devices", "/api/v1/audit")
    ]
    found = _instants(answers)
    assert any(key == "departed_at" for key, _ in found)
    wrong = [(key, value) for key, value in found if not INSTANT.match(value)]
    assert not wrong, wrong


def test_instant_format_drops_microseconds_and_writes_z() -> None:
    at = datetime(2026, 11, 30, 17, 54, 11, 250_999, tzinfo=UTC)
    assert format_instant(at) == "2026-11-30T17:54:11.250Z"
    assert format_instant(at.replace(microsecond=0)) == "2026-11-30T17:54:11Z"
    assert format_instant(at.replace(tzinfo=None)) == "2026-11-30T17:54:11.250Z"


def test_a_band_whose_edges_would_overflow_is_refused(client: TestClient) -> None:
    body = {"name": "huge", "nominal": -1.7976931348623157e308, "tolerance": 4.9e307}
    answer = client.post("/api/v1/maintenance/parameters", json=body, headers=ADMIN)
    assert answer.status_code == 422
    assert answer.headers["content-type"].startswith("application/problem+json")
