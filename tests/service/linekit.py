"""Building a small line through the real API, for the service tests."""

from __future__ import annotations

from typing import Any

from fastapi.testclient import TestClient

from tests.conftest import ADMIN

DEVICES = [
    ("A-ilk", "A", None, "interlocking"),
    ("B-ilk", "B", None, "interlocking"),
    ("A-cam", "A", "AB", "camera"),
    ("B-cam", "B", "AB", "camera"),
    ("A-ac", "A", "AB", "axle_counter"),
    ("B-ac", "B", "AB", "axle_counter"),
    ("A-ir", "A", "AB", "ir_reader"),
    ("B-ir", "B", "AB", "ir_reader"),
    ("A-wm", "A", "AB", "wheel_mark_reader"),
    ("B-wm", "B", "AB", "wheel_mark_reader"),
    ("D-mark", "A", None, "marking_station"),
    ("D-bench", "A", None, "test_bench"),
    ("T-obu", "A", None, "onboard_unit"),
    ("B-eot", "B", "AB", "eot_receiver"),
]


def post_ok(client: TestClient, path: str, body: dict[str, Any]) -> dict[str, Any]:
    response = client.post(path, json=body, headers=ADMIN)
    assert response.status_code == 201, response.text
    result: dict[str, Any] = response.json()
    return result


def build_line(client: TestClient, *, mode: str = "primary") -> dict[str, dict[str, str]]:
    """Stations A, B, C; sections AB (given mode) and BC; a device of every kind; four cars.

    Returns the device headers by device id.
    """
    for ident, name in (("A", "Anan'iv"), ("B", "Birzula"), ("C", "Chornomorsk")):
        post_ok(client, "/api/v1/stations", {"id": ident, "name": name})
    post_ok(
        client,
        "/api/v1/sections",
        {"id": "AB", "from_station": "A", "to_station": "B", "mode": mode},
    )
    post_ok(
        client,
        "/api/v1/sections",
        {"id": "BC", "from_station": "B", "to_station": "C", "mode": "primary"},
    )
    keys = {}
    for ident, station, section, kind in DEVICES:
        body = {"id": ident, "station": station, "section": section, "kind": kind}
        keys[ident] = {"X-Device-Key": post_ok(client, "/api/v1/devices", body)["key"]}
    for number in (117, 118, 119, 120):
        post_ok(
            client,
            "/api/v1/cars",
            {"id": f"0{number}", "wheel_code": number, "ir_number": number, "axles": 4},
        )
    return keys


def event(
    event_id: str, kind: str, at: str = "2026-11-23T10:15:00Z", **fields: Any
) -> dict[str, Any]:
    return {"event_id": event_id, "occurred_at": at, "kind": kind, **fields}


# The maintenance parameters the fleet tests measure (values must name registered ones).
BANDS = (
    {"name": "door_close_s", "nominal": 2.4, "tolerance": 0.5, "unit": "s"},
    {"name": "brake_release_s", "nominal": 4.0, "tolerance": 1.0, "unit": "s"},
    {"name": "brake_cylinder_fill_s", "nominal": 5.0, "tolerance": 1.5, "unit": "s"},
)


def register_bands(client: TestClient) -> None:
    """Register BANDS (a parameter registered before is left as it is)."""
    for band in BANDS:
        answer = client.post("/api/v1/maintenance/parameters", json=band, headers=ADMIN)
        assert answer.status_code in (201, 409), answer.text
