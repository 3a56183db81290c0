"""Motion samples of one train from two on-board units, and batches out of order, through
the real event API (found by the independent trial).

* A second unit reporting for the same train (a unit in each cab, a replacement fitted)
  runs its own clock: its samples were "far behind" or "far ahead" of the first unit's, so
  each unit's samples in turn started the train's filter again — the position was wiped
  over and over.  Each unit now has its own filter; the train's answer is the unit that
  reported last, and ``devices`` shows every unit's own estimate.
* A batch whose samples come out of order within the late-sample bound
  (``FilterConfig.max_delay_s``) is used whole; a sample later than the bound is refused
  in the batch's answer with the reason, naming the bound.
"""

from __future__ import annotations

import random
from datetime import timedelta

from fastapi.testclient import TestClient

from motion.fusion import FilterConfig
from tests.conftest import ADMIN
from tests.service.clock import ServerClock, server_clock  # noqa: F401 (fixture)
from tests.service.linekit import build_line, post_ok
from tests.service.scenario import T0
from tests.service.test_service_trains import samples, track

EVENTS = "/api/v1/events"
POSITION = "/api/v1/trains/2041/position"


def _second_unit(client: TestClient) -> dict[str, str]:
    body = {"id": "T-obu2", "station": "A", "section": None, "kind": "onboard_unit"}
    return {"X-Device-Key": post_ok(client, "/api/v1/devices", body)["key"]}


def _markers(client: TestClient) -> None:
    for ident, track_m in (("M0", 0.0), ("M1", 600.0), ("M2", 2400.0)):
        post_ok(client, "/api/v1/markers", {"id": ident, "track_m": track_m, "section": "AB"})


def _post(client: TestClient, batch: list[dict], headers: dict[str, str]) -> list[dict]:
    response = client.post(EVENTS, json={"events": batch}, headers=headers)
    assert response.status_code == 200, response.text
    results: list[dict] = response.json()["results"]
    return results


def test_two_units_on_one_train_never_wipe_each_other(
    client: TestClient,
    server_clock: ServerClock,  # noqa: F811
) -> None:
    server_clock.set(T0 + timedelta(seconds=91))
    keys = build_line(client)
    second = _second_unit(client)
    _markers(client)
    first_unit = samples(90, {0.0: "M0", 600.0: "M1"})
    # the other cab's unit: its own clock (started 5000 s later), its own event ids
    other_unit = [
        body | {"event_id": f"u2-{i}", "t": body["t"] + 5000.0} for i, body in enumerate(first_unit)
    ]
    for start in range(0, len(first_unit), 100):  # ten seconds each, in turn
        for batch, headers in ((first_unit, keys["T-obu"]), (other_unit, second)):
            results = _post(client, batch[start : start + 100], headers)
            assert all(r["status"] == "created" for r in results)
            refused = [r for r in results if r["result"].get("warning")]
            assert not refused, refused[0]
    position = client.get(POSITION, headers=ADMIN).json()
    expected = track(89.9)[0]
    assert position["position_known"] and abs(position["position_m"] - expected) < 5.0, position
    assert abs(position["speed_mps"] - 20.0) < 0.5
    assert position["device"] == "T-obu2"
    units = {unit["device"]: unit for unit in position["devices"]}
    assert set(units) == {"T-obu", "T-obu2"}
    for unit in units.values():
        assert unit["position_known"] and abs(unit["position_m"] - expected) < 5.0, unit
    assert units["T-obu"]["t"] == 89.9 and units["T-obu2"]["t"] == 5089.9


def test_a_batch_out_of_order_within_the_bound_is_used_whole(
    client: TestClient,
    server_clock: ServerClock,  # noqa: F811
) -> None:
    server_clock.set(T0 + timedelta(seconds=91))
    keys = build_line(client)
    _markers(client)
    batch = samples(60, {0.0: "M0"})
    bound = FilterConfig().max_delay_s
    rng = random.Random(4)
    late = [body["t"] + rng.uniform(0.0, 0.8 * bound) for body in batch]
    shuffled = [body for _, body in sorted(zip(late, batch, strict=True), key=lambda p: p[0])]
    results = []
    for start in range(0, len(shuffled), 200):
        results += _post(client, shuffled[start : start + 200], keys["T-obu"])
    refused = [r for r in results if r["result"]["position"] is None]
    assert all(r["status"] == "created" for r in results) and not refused, refused[:1]
    position = client.get(POSITION, headers=ADMIN).json()
    assert position["t"] == 59.9 and abs(position["speed_mps"] - 20.0) < 0.5


def test_a_sample_later_than_the_bound_is_refused_with_the_reason(
    client: TestClient,
    server_clock: ServerClock,  # noqa: F811
) -> None:
    server_clock.set(T0 + timedelta(seconds=91))
    keys = build_line(client)
    batch = samples(30, {})
    old = batch[50] | {"event_id": "late-one"}
    results = _post(client, [*batch[100:], old], keys["T-obu"])
    assert results[-1]["status"] == "created"
    answer = results[-1]["result"]
    assert answer["position"] is None
    assert "max_delay_s" in answer["warning"] and "refused" in answer["warning"], answer
