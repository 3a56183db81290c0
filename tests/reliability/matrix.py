"""The endpoint × role table of protocol.md, shared by the access and schema tests.

A new endpoint is one line in ``ENDPOINTS``: method, path (as in the OpenAPI document) and the
roles that may call it.
"""

from __future__ import annotations

from tests.service.linekit import DEVICES

KIND_OF = {ident: kind for ident, _, _, kind in DEVICES}
DEVICE_ROLES = {f"device:{kind}": ident for ident, _, _, kind in reversed(DEVICES)}
PEOPLE = ("dispatcher", "engineer", "admin")
ROLES = ("anonymous", *PEOPLE, *sorted(DEVICE_ROLES))

PUBLIC = frozenset(ROLES)
READERS = frozenset(PEOPLE)
ADMIN_ONLY = frozenset({"admin"})
DISPATCH = frozenset({"admin", "dispatcher"})
ENGINEER = frozenset({"admin", "engineer"})
DEVICES_ANY = frozenset(DEVICE_ROLES)
CAMERA = frozenset({"device:camera"})

# (method, path, who may) — path parameters are filled from PARAMS.
ENDPOINTS: list[tuple[str, str, frozenset[str]]] = [
    ("GET", "/healthz", PUBLIC),
    ("GET", "/readyz", PUBLIC),
    ("POST", "/api/v1/stations", ADMIN_ONLY),
    ("GET", "/api/v1/stations", READERS),
    ("GET", "/api/v1/stations/{station_id}", READERS),
    ("POST", "/api/v1/sections", ADMIN_ONLY),
    ("GET", "/api/v1/sections", READERS),
    ("GET", "/api/v1/sections/{section_id}", READERS),
    ("POST", "/api/v1/devices", ADMIN_ONLY),
    ("GET", "/api/v1/devices", READERS),
    ("GET", "/api/v1/devices/{device_id}", READERS),
    ("POST", "/api/v1/devices/{device_id}/key", ADMIN_ONLY),
    ("POST", "/api/v1/devices/{device_id}/decommission", ADMIN_ONLY),
    ("GET", "/api/v1/users", ADMIN_ONLY),
    ("POST", "/api/v1/users", ADMIN_ONLY),
    ("POST", "/api/v1/users/{name}/rotate", ADMIN_ONLY),
    ("POST", "/api/v1/users/{name}/revoke", ADMIN_ONLY),
    ("GET", "/api/v1/credential-changes", ADMIN_ONLY),
    ("GET", "/api/v1/events", DISPATCH),  # transports.md: the raw event log
    ("POST", "/api/v1/cars", ADMIN_ONLY),
    ("GET", "/api/v1/cars", READERS),
    ("GET", "/api/v1/cars/{car_id}", READERS),
    ("GET", "/api/v1/cars/{car_id}/wheel-markings", READERS),
    ("POST", "/api/v1/events", DEVICES_ANY),
    ("POST", "/api/v1/snapshots", CAMERA),
    ("GET", "/api/v1/runs", READERS),
    ("GET", "/api/v1/runs/{run_id}", READERS),
    ("POST", "/api/v1/runs/{run_id}/decision", DISPATCH),
    ("GET", "/api/v1/audit", READERS),
    ("GET", "/api/v1/snapshots/{snapshot_id}", READERS),
    ("GET", "/api/v1/snapshots/{snapshot_id}/meta", READERS),
    ("GET", "/api/v1/snapshots/{snapshot_id}/overlay", READERS),
    ("POST", "/api/v1/cars/{car_id}/measurements", ENGINEER),
    ("POST", "/api/v1/maintenance/forecasts", ENGINEER),
    ("GET", "/api/v1/cars/{car_id}/forecast", READERS),
    ("GET", "/api/v1/cars/{car_id}/forecast.png", READERS),
    ("GET", "/api/v1/maintenance/fleet", READERS),
    ("GET", "/api/v1/maintenance/parameters", READERS),
    ("POST", "/api/v1/maintenance/parameters", ENGINEER),
    ("PUT", "/api/v1/maintenance/parameters/{name}", ENGINEER),
    ("POST", "/api/v1/cars/{car_id}/maintenance-decision", ENGINEER),
    ("GET", "/api/v1/trains/{train}/position", READERS),
    ("POST", "/api/v1/motion/braking-plan", READERS),  # a calculator: no state changed
    ("POST", "/api/v1/markers", ADMIN_ONLY),
    ("GET", "/api/v1/markers", READERS),
    ("GET", "/metrics", ADMIN_ONLY),  # or DEPOT_METRICS_TOKEN (test_service_metrics.py)
]
