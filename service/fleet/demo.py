"""Demo history for the maintenance feature, posted through the real API.

Parameters and their bands are registered, then months of test-bench measurements per car go
in as ``measurement`` events from the test bench (a few cars wear towards a fault, see
:mod:`maintenance.simulate`), and the fleet forecast is computed.
"""

from __future__ import annotations

from datetime import datetime, timedelta
from typing import Any

from maintenance.simulate import PARAMETERS, SimulatedFleet, simulate_fleet
from service.inprocess import TestClient

TESTS_PER_CAR = 100  # one bench test every TEST_INTERVAL: about seven months of history
TEST_INTERVAL = timedelta(days=2)
HORIZON = 30
SEED = 2041
BATCH = 1000  # the protocol's largest event batch
UNITS = {
    "_s": "s", "_mohm": "MOhm", "_a": "A", "_c": "degC", "_v": "V", "_n": "N", "_mm": "mm",
    "_g": "g", "_db": "dB", "_bar_min": "bar/min",
}  # fmt: skip


def unit_of(name: str) -> str:
    return next((unit for suffix, unit in UNITS.items() if name.endswith(suffix)), "")


def demo_fleet(n_cars: int, *, seed: int = SEED) -> SimulatedFleet:
    """The simulated fleet behind :func:`load_fleet_history` (truth included, for checks)."""
    return simulate_fleet(
        n_cars, n_times=TESTS_PER_CAR, horizon=HORIZON, degrading_fraction=0.3, seed=seed
    )


def _check(response: Any, what: str, ok: tuple[int, ...]) -> Any:
    if response.status_code not in ok:
        raise RuntimeError(f"fleet demo {what}: {response.status_code} {response.text}")
    return response.json()


def register_parameters(client: TestClient, admin_headers: dict[str, str]) -> None:
    for name, nominal, tolerance, kind in PARAMETERS:
        body = {
            "name": name,
            "nominal": nominal,
            "tolerance": tolerance,
            "unit": unit_of(name),
            "description": f"{kind} parameter of the bench test",
        }
        response = client.post("/api/v1/maintenance/parameters", json=body, headers=admin_headers)
        _check(response, f"parameter {name}", (201, 409))  # 409: loaded before


def bench_events(cars: list[str], fleet: SimulatedFleet, end: datetime) -> list[dict[str, Any]]:
    events = []
    for c, car in enumerate(cars):
        # Cars visit the bench at different hours; the last test of each is just before ``end``.
        last = end - timedelta(minutes=17 * (c + 1))
        for i in range(TESTS_PER_CAR):
            at = last - (TESTS_PER_CAR - 1 - i) * TEST_INTERVAL
            row = zip(fleet.names, fleet.histories[c, i], strict=True)
            values = {n: round(float(v), 4) for n, v in row}
            events.append(
                {
                    "event_id": f"D-bench-{car}-{i:04d}",
                    "occurred_at": at.isoformat(),
                    "kind": "measurement",
                    "car": car,
                    "values": values,
                }
            )
    return events


def load_fleet_history(
    client: TestClient,
    admin_headers: dict[str, str],
    bench_headers: dict[str, str],
    cars: list[str],
    *,
    end: datetime,
) -> None:
    """Register parameters, post every car's bench history, then forecast the fleet."""
    register_parameters(client, admin_headers)
    events = bench_events(cars, demo_fleet(len(cars)), end)
    for start in range(0, len(events), BATCH):
        body = {"events": events[start : start + BATCH]}
        result = _check(client.post("/api/v1/events", json=body, headers=bench_headers),
                        "bench events", (200,))  # fmt: skip
        refused = [r for r in result["results"] if r["status"] == "rejected"]
        if refused:
            raise RuntimeError(f"fleet demo: {len(refused)} bench events refused: {refused[0]}")
    _check(client.post("/api/v1/maintenance/forecasts", headers=admin_headers), "forecast", (201,))
