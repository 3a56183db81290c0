"""Train position from motion samples, through the real event API."""

from __future__ import annotations

from datetime import timedelta

import pytest
from fastapi.testclient import TestClient

from tests.conftest import ADMIN
from tests.service.clock import ServerClock, server_clock  # noqa: F401 (fixture)
from tests.service.linekit import build_line, post_ok
from tests.service.scenario import T0, iso


def track(t: float) -> tuple[float, float, float]:
    """Start from standstill at 0.5 m/s² to 20 m/s (40 s, 400 m), then cruise."""
    if t <= 40.0:
        return 0.25 * t * t, 0.5 * t, 0.5
    return 400.0 + 20.0 * (t - 40.0), 20.0, 0.0


def samples(seconds: int, markers: dict[float, str]) -> list[dict]:
    """10 Hz accelerometer, GNSS speed each second (1.5 s late), marker reads."""
    out = []
    for i in range(seconds * 10):
        t = i / 10
        position, _, accel = track(t)
        body = {
            "event_id": f"m-{i}",
            "occurred_at": iso(T0 + timedelta(seconds=t)),
            "kind": "motion_sample",
            "train": "2041",
            "t": t,
            "accel_mps2": accel,
        }
        if i % 10 == 0 and t >= 1.5:
            body |= {"gnss_speed_mps": track(t - 1.5)[1], "gnss_delay_s": 1.5}
        next_position = track(t + 0.1)[0]
        for at, marker in markers.items():
            if position <= at < next_position or (at == 0.0 and i == 0):
                body["marker_id"] = marker
        out.append(body)
    return out


def test_position_follows_markers_and_gnss(
    client: TestClient,
    server_clock: ServerClock,  # noqa: F811
) -> None:
    server_clock.set(T0 + timedelta(seconds=91))  # a second after the newest sample
    keys = build_line(client)
    for ident, track_m in (("M0", 0.0), ("M1", 600.0), ("M2", 2400.0)):
        post_ok(client, "/api/v1/markers", {"id": ident, "track_m": track_m, "section": "AB"})
    batch = samples(90, {0.0: "M0", 600.0: "M1"})
    response = client.post("/api/v1/events", json={"events": batch}, headers=keys["T-obu"])
    assert response.status_code == 200
    assert {r["status"] for r in response.json()["results"]} == {"created"}
    position = client.get("/api/v1/trains/2041/position", headers=ADMIN).json()
    expected = track(89.9)[0]
    assert abs(position["position_m"] - expected) < 5.0, position
    assert abs(position["speed_mps"] - 20.0) < 0.5
    assert position["sigma_position_m"] < 10.0 and position["section"] == "AB"


def test_position_unknown_train_and_roles(client: TestClient) -> None:
    keys = build_line(client)
    assert client.get("/api/v1/trains/9999/position", headers=ADMIN).status_code == 404
    assert client.get("/api/v1/trains/9999/position").status_code == 401
    assert client.get("/api/v1/trains/9999/position", headers=keys["T-obu"]).status_code == 403
    duplicate = {"id": "M0", "track_m": 0.0}
    post_ok(client, "/api/v1/markers", duplicate)
    assert client.post("/api/v1/markers", json=duplicate, headers=ADMIN).status_code == 409
    bad = client.post("/api/v1/markers", json={"id": "M9", "track_m": -1}, headers=ADMIN)
    assert bad.status_code == 422


def _moving_start(seconds: int, speed: float) -> list[dict]:
    """The independent trial's batch: 1 Hz, accel 0, GNSS 1 s late, train already moving."""
    return [
        {
            "event_id": f"mv-{i}",
            "occurred_at": iso(T0 + timedelta(seconds=i)),
            "kind": "motion_sample",
            "train": "T7",
            "t": float(i),
            "accel_mps2": 0.0,
            "gnss_speed_mps": speed,
            "gnss_delay_s": 1.0,
        }
        for i in range(seconds)
    ]


def test_a_train_seen_first_while_moving_follows_gnss(
    client: TestClient,
    server_clock: ServerClock,  # noqa: F811
) -> None:
    server_clock.set(T0 + timedelta(seconds=1))
    keys = build_line(client)
    first = client.post(
        "/api/v1/events", json={"events": _moving_start(1, 15.0)}, headers=keys["T-obu"]
    )
    assert first.status_code == 200
    position = client.get("/api/v1/trains/T7/position", headers=ADMIN).json()
    # one sample, its GNSS speed older than the filter: the speed is not known yet
    assert position["speed_known"] is False and position["direction"] == 0
    batch = _moving_start(300, 15.0)[1:]
    server_clock.set(T0 + timedelta(seconds=300))
    response = client.post("/api/v1/events", json={"events": batch}, headers=keys["T-obu"])
    assert response.status_code == 200
    position = client.get("/api/v1/trains/T7/position", headers=ADMIN).json()
    assert position["speed_known"] is True
    assert abs(position["speed_mps"] - 15.0) <= 3 * position["sigma_speed_mps"] + 1e-9


def test_an_impossible_clock_is_refused_naming_t(client: TestClient) -> None:
    keys = build_line(client)
    bad = _moving_start(1, 15.0)[0] | {"t": 1e308}
    response = client.post("/api/v1/events", json={"events": [bad]}, headers=keys["T-obu"])
    text = response.text
    assert "t must be within" in text and "cannot be stored" not in text, text


def test_an_on_board_restart_is_followed_through_the_api(
    client: TestClient,
    server_clock: ServerClock,  # noqa: F811
) -> None:
    """The unit reboots after 100 s: its clock starts again at 0.5 s.  The first
    samples after it are refused as old, then the restart is taken (the count kept
    in the train's stored filter between samples) and the speed follows GNSS again."""
    keys = build_line(client)
    before = _moving_start(100, 15.0)
    after = [
        body
        | {"event_id": f"rb-{i}", "t": 0.5 + i, "occurred_at": iso(T0 + timedelta(seconds=101 + i))}
        for i, body in enumerate(_moving_start(20, 15.0))
    ]
    server_clock.set(T0 + timedelta(seconds=121))
    for batch in (before, after):
        response = client.post("/api/v1/events", json={"events": batch}, headers=keys["T-obu"])
        assert response.status_code == 200
    position = client.get("/api/v1/trains/T7/position", headers=ADMIN).json()
    assert position["t"] == 19.5, position
    assert position["speed_known"] is True and abs(position["speed_mps"] - 15.0) < 0.5


def test_a_position_no_sample_has_renewed_is_not_known(
    client: TestClient,
    server_clock: ServerClock,  # noqa: F811
) -> None:
    """Found by an independent trial: 90 s after a train's last sample its old coordinate
    was still "known" with σ 0.4 m, although the train had run 1.8 km on. A unit silent for
    longer than any device may be (DEPOT_HEARTBEAT_S) gives no position, speed or section."""
    keys = build_line(client)
    for ident, track_m in (("M0", 0.0), ("M1", 600.0), ("M2", 2400.0)):
        post_ok(client, "/api/v1/markers", {"id": ident, "track_m": track_m, "section": "AB"})
    server_clock.set(T0 + timedelta(seconds=90))
    batch = samples(90, {0.0: "M0", 600.0: "M1"})
    response = client.post("/api/v1/events", json={"events": batch}, headers=keys["T-obu"])
    assert response.status_code == 200
    newest = T0 + timedelta(seconds=89.9)
    server_clock.set(newest + timedelta(seconds=30))
    fresh = client.get("/api/v1/trains/2041/position", headers=ADMIN).json()
    assert fresh["stale"] is False and fresh["position_known"] and fresh["section"] == "AB"
    assert fresh["age_s"] == pytest.approx(30.0, abs=0.01)
    for late in (61.0, 90.0, 3600.0):
        server_clock.set(newest + timedelta(seconds=late))
        old = client.get("/api/v1/trains/2041/position", headers=ADMIN).json()
        assert old["stale"] is True, (late, old)
        assert old["position_known"] is False and old["speed_known"] is False, old
        assert old["section"] is None, old
