"""Fleet forecasts end to end: a generated fleet posted as bench events, ranked by risk."""

from __future__ import annotations

from datetime import UTC, datetime, timedelta

import numpy as np
import pytest
from fastapi.testclient import TestClient
from sqlalchemy import select
from sqlalchemy.orm import Session

from service.fleet.demo import demo_fleet, load_fleet_history, register_parameters
from service.fleet.forecasts import (
    ForecastOptions,
    assess,
    assessed,
    calibrate_fleet_index,
    forecast_row,
)
from service.fleet.history import Block, Columns, car_history, histories, load_bands
from service.fleet.models import Forecast, Measurement, decode_readings
from service.fleet.service import record_measurements
from service.fleet.vectorised import batch_assessments
from tests.conftest import ADMIN
from tests.service.linekit import build_line, post_ok

END = datetime(2026, 11, 23, 6, 0, tzinfo=UTC)
FLEET = [f"0{n}" for n in range(201, 217)]  # 16 cars: 3 of them leave tolerance within 30 tests


LINE_CARS = ["0117", "0118", "0119", "0120"]


@pytest.fixture
def stored(client: TestClient, session: Session) -> list[str]:
    """The line's four cars with 100 bench tests each, stored directly, and a forecast run."""
    build_line(client)
    register_parameters(client, ADMIN)
    fleet = demo_fleet(len(LINE_CARS), seed=5)
    for c, car in enumerate(LINE_CARS):
        for i in range(fleet.histories.shape[1]):
            at = END - timedelta(days=2 * (fleet.histories.shape[1] - 1 - i), minutes=c)
            values = dict(zip(fleet.names, fleet.histories[c, i].tolist(), strict=True))
            record_measurements(session, car, at, values, source="api")
    response = client.post("/api/v1/maintenance/forecasts", headers=ADMIN)
    assert response.status_code == 201, response.text
    return LINE_CARS


def test_generated_fleet_ranks_drifting_cars_first(client: TestClient, session: Session) -> None:
    """The demo's path: bench ``measurement`` events through the API, then the fleet ranking."""
    keys = build_line(client)
    for car in FLEET:
        post_ok(client, "/api/v1/cars", {"id": car})
    load_fleet_history(client, ADMIN, keys["D-bench"], FLEET, end=END)
    response = client.get("/api/v1/maintenance/fleet", headers=ADMIN)
    assert response.status_code == 200
    loaded = response.json()
    truth = demo_fleet(len(FLEET))
    leaving = {car for car, out in zip(FLEET, truth.leaves_within_horizon, strict=True) if out}
    assert len(leaving) == 3
    ranked = [c for c in loaded["cars"] if c["car"] in FLEET]
    assert [c["rank"] for c in ranked] == sorted(c["rank"] for c in ranked)
    top = {c["car"] for c in ranked[: len(leaving)]}
    assert top == leaving, [(c["car"], c["risk"]) for c in ranked[:6]]
    for car in ranked[: len(leaving)]:
        assert car["risk"] >= 0.5 and car["recommendation"] == "plan_withdrawal"
        assert set(car["weights"]) == set(truth.names) and car["contributions"]
    never = {car for car, d in zip(FLEET, truth.degrading, strict=True) if not d}
    assert all(c["risk"] < 0.5 for c in ranked if c["car"] in never)
    # the cars of the line without measurements come last, without a risk
    assert [c["status"] for c in loaded["cars"][-4:]] == ["not_enough_history"] * 4
    stored = session.scalars(select(Measurement).where(Measurement.car_id == FLEET[0])).all()
    assert len(stored) == 100  # one row per test
    assert all(len(decode_readings(m.readings)) == len(truth.names) for m in stored)
    assert {m.source for m in stored} == {"event"} and all(m.raw_event_id for m in stored)


def test_car_forecast_has_history_interval_band_and_reasons(
    stored: list[str], client: TestClient
) -> None:
    car = stored[0]
    body = client.get(f"/api/v1/cars/{car}/forecast", headers=ADMIN).json()
    assert body["status"] == "ok" and body["n_measurements"] == 100
    assert len(body["index_history"]) == 100
    assert body["index_history"][-1]["at"].startswith("2026-11-23")
    steps = body["forecast"]["steps"]
    assert len(steps) == 30 and all(s["lower"] <= s["value"] <= s["upper"] for s in steps)
    assert datetime.fromisoformat(steps[0]["at"]) - datetime.fromisoformat(
        body["index_history"][-1]["at"]
    ) == timedelta(days=2)
    lo, hi = body["index_band"]
    assert lo < 1.0 < hi
    assert "fleet prediction weights" in body["calibration"]
    assert body["reasons"] and "index" in body["reasons"][0]
    assert set(body["bands"]["brake_cylinder_fill_s"]) == {"lower", "upper", "unit"}
    assert body["bands"]["brake_cylinder_fill_s"]["lower"] == pytest.approx(2.4)
    # contributions add up to the index deviation now (the package's identity)
    now = body["index_history"][-1]["index"]
    assert sum(body["contributions"].values()) == pytest.approx(now - 1.0, abs=1e-9)
    assert body["override"] is None and body["overrides"] == []


def test_forecasts_are_appended_and_the_latest_counts(
    stored: list[str], client: TestClient, session: Session
) -> None:
    car = stored[0]
    first = client.get(f"/api/v1/cars/{car}/forecast", headers=ADMIN).json()
    response = client.post(
        "/api/v1/maintenance/forecasts", json={"method": "inverse_variance"}, headers=ADMIN
    )
    assert response.status_code == 201, response.text
    assert response.json()["cars"] == len(stored)
    again = client.get(f"/api/v1/cars/{car}/forecast", headers=ADMIN).json()
    assert again["forecast_id"] > first["forecast_id"] and again["method"] == "inverse_variance"
    rows = session.scalars(select(Forecast).where(Forecast.car_id == car)).all()
    assert len(rows) == 2


def test_chart_is_a_png(stored: list[str], client: TestClient) -> None:
    response = client.get(f"/api/v1/cars/{stored[0]}/forecast.png", headers=ADMIN)
    assert response.status_code == 200
    assert response.headers["content-type"] == "image/png"
    assert response.content[:8] == b"\x89PNG\r\n\x1a\n"
    import cv2

    image = cv2.imdecode(np.frombuffer(response.content, np.uint8), cv2.IMREAD_COLOR)
    assert image.shape[:2] == (300, 760)


def _blocks_of(tests: list[tuple[int, int, tuple[str, ...], list[float]]]) -> list[Block]:
    """Blocks (one per layout) of tests ``(day, id, names, readings)``."""
    out = []
    for names in dict.fromkeys(names for _, _, names, _ in tests):
        mine = [t for t in tests if t[2] == names]
        epoch = [datetime(2026, 1, day, tzinfo=UTC).timestamp() for day, *_ in mine]
        out.append(Block(LAYOUTS.index(names), np.array(epoch), np.array([t[1] for t in mine]),
                         np.array([t[3] for t in mine])))  # fmt: skip
    return out


LAYOUTS = [("a", "b"), ("a",), ("b",), ("a", "c"), ("x",)]


def test_history_carries_skipped_values_and_drops_rare_parameters() -> None:
    names = ["a", "b", "c"]
    columns = {
        0: Columns([0, 1], [0, 1]), 1: Columns([0], [0]), 2: Columns([0], [1]),
        3: Columns([0, 1], [0, 2]),
    }  # fmt: skip
    tests = [(1, 1, ("a", "b"), [1.0, 5.0]), (2, 2, ("a",), [2.0]), (3, 3, ("a", "b"), [3.0, 6.0])]
    tests += [(4, 4, ("b",), [7.0]), (5, 5, ("a",), [4.0]), (5, 6, ("a", "c"), [4.5, 9.0])]
    tests += [(5, 7, ("x",), [0.0])]  # a layout without banded parameters
    history = car_history("0117", _blocks_of(tests), columns, names)
    assert history is not None and history.names == ("a", "b")  # c measured once in five tests
    assert history.taken_at == [datetime(2026, 1, d, tzinfo=UTC) for d in range(1, 6)]
    np.testing.assert_allclose(
        history.values, [[1, 5], [2, 5], [3, 6], [3, 7], [4.5, 7]]
    )  # skipped values carried forward; a repeated measurement keeps the later value
    single = car_history("0118", _blocks_of(tests[:1] + tests[2:3]), columns, names)
    assert single is not None and single.names == ("a", "b")
    np.testing.assert_array_equal(single.values, [[1, 5], [3, 6]])
    assert car_history("0119", _blocks_of(tests[-1:]), columns, names) is None


def test_stored_histories_read_in_bulk(client: TestClient, session: Session) -> None:
    """Ragged storage (several layouts) reads the same on every database; a second test at a
    stored time is not stored (the unique index of migration 0009), the first one is read."""
    build_line(client)
    for name in ("a", "b", "c"):
        body = {"name": name, "nominal": 1.0, "tolerance": 0.5}
        post_ok(client, "/api/v1/maintenance/parameters", body)
    t = [END - timedelta(days=5 - d, microseconds=250_000) for d in range(5)]
    ragged = [(t[0], {"a": 1.0, "b": 5.0}), (t[1], {"a": 2.0}), (t[2], {"b": 6.0, "a": 3.0})]
    ragged += [(t[3], {"b": 7.0, "z": 0.0}), (t[4], {"a": 4.0}), (t[4], {"a": 4.5, "c": 9.0})]
    stored = [record_measurements(session, "0117", at, v, source="api") for at, v in ragged]
    assert stored == [2, 1, 2, 2, 1, 0]
    for at, values in ragged[:3:2]:
        record_measurements(session, "0118", at, values, source="api")
    record_measurements(session, "0119", t[0], {"z": 1.0}, source="api")  # no banded parameter
    session.flush()
    read = {h.car_id: h for h in histories(session, load_bands(session).names)}
    assert sorted(read) == ["0117", "0118"]
    assert read["0117"].names == ("a", "b") and read["0117"].taken_at == t
    np.testing.assert_allclose(read["0117"].values, [[1, 5], [2, 5], [3, 6], [3, 7], [4, 7]])
    assert read["0118"].names == ("a", "b") and read["0118"].taken_at == [t[0], t[2]]
    np.testing.assert_array_equal(read["0118"].values, [[1, 5], [3, 6]])


def test_vectorised_assessment_equals_per_car(stored: list[str], session: Session) -> None:
    bands, options = load_bands(session), ForecastOptions()
    read = list(histories(session, bands.names))
    fleet = calibrate_fleet_index(read, bands, options)
    assert fleet.calibrated and len(read) == len(stored)
    batch = batch_assessments(read, bands, fleet, order=2, horizon=30, failure_k=2)
    assert sorted(batch) == list(range(len(read)))
    for i, history in enumerate(read):
        got, (want, _) = batch[i].to_dict(), assess(history, bands, fleet, options)
        want_d = want.to_dict()
        assert got["reasons"] == want_d["reasons"] and got["first_exit"] == want_d["first_exit"]
        for key in ("risk", "k_of_l_probability", "times", "index"):
            np.testing.assert_allclose(got[key], want_d[key], rtol=1e-9, atol=1e-12)
        for key in ("times", "values", "lower", "upper"):
            np.testing.assert_allclose(got["forecast"][key], want_d["forecast"][key], rtol=1e-9)
        rows = [forecast_row(history, bands, fleet, options, END, o) for o in
                (assessed(batch[i], fleet.note), None)]  # fmt: skip
        assert rows[0]["payload"]["reasons"] == rows[1]["payload"]["reasons"]


def test_review_fleet_page_behind_login(stored: list[str], client: TestClient) -> None:
    page = client.get("/review/fleet", follow_redirects=False)
    assert page.status_code == 303 and page.headers["location"] == "/review/login"
    assert client.get(f"/review/fleet/cars/{stored[0]}/forecast.png").status_code == 401
    login = client.post("/review/login", data={"token": ADMIN["Authorization"][7:]})
    assert login.status_code == 200  # followed to /review
    html = client.get("/review/fleet").text
    assert 'id="ranking"' in html
    for car in stored:
        assert f'data-car="{car}"' in html
        assert f'src="/review/fleet/cars/{car}/forecast.png"' in html
    chart = client.get(f"/review/fleet/cars/{stored[0]}/forecast.png")
    assert chart.status_code == 200 and chart.content[:4] == b"\x89PNG"
    short = client.post(
        f"/review/fleet/cars/{stored[1]}/decision", data={"action": "withdraw_now", "reason": "x"}
    )
    assert "Give a reason of at least 3 letters or digits." in short.text
    decided = client.post(
        f"/review/fleet/cars/{stored[1]}/decision",
        data={"action": "withdraw_now", "reason": "compressor fill time creeping up"},
    )
    assert decided.status_code == 200 and "withdrawn now" in decided.text
    assert "“compressor fill time creeping up”" in decided.text
    body = client.get(f"/api/v1/cars/{stored[1]}/forecast", headers=ADMIN).json()
    assert body["decision"] == "withdraw_now" and body["override"]["actor"] == "admin"


def test_fleet_page_filters_pages_and_sets_withdrawn_cars_apart(
    stored: list[str], client: TestClient
) -> None:
    client.post("/review/login", data={"token": ADMIN["Authorization"][7:]})
    fleet = client.get("/api/v1/maintenance/fleet", headers=ADMIN).json()
    assert [c["rank"] for c in fleet["cars"]] == list(range(1, len(stored) + 1))
    for car in fleet["cars"]:  # a car out of its band now is never "expected out … ahead"
        if car["out_of_band_now"]:
            assert car["reasons"][0].startswith("already outside its band"), car["reasons"]
        assert not any("1 tests" in reason for reason in car["reasons"]), car["reasons"]
    html = client.get("/review/fleet").text
    assert "is <b>faulty</b> when" in html and 'id="legend"' in html
    one = client.get(f"/review/fleet?car={stored[0]}").text
    assert f'data-car="{stored[0]}"' in one and f'data-car="{stored[1]}"' not in one
    assert f"1 of {len(stored)} cars in service" in one
    withdrawn = client.post(
        f"/api/v1/cars/{stored[2]}/maintenance-decision",
        json={"action": "withdraw_now", "reason": "wheel flat, sent to the shop"},
        headers=ADMIN,
    )
    assert withdrawn.status_code == 201
    fleet = client.get("/api/v1/maintenance/fleet", headers=ADMIN).json()
    assert stored[2] not in [c["car"] for c in fleet["cars"]]
    assert [c["car"] for c in fleet["withdrawn"]] == [stored[2]]
    assert [c["rank"] for c in fleet["cars"]] == list(range(1, len(stored)))
    html = client.get("/review/fleet").text
    assert f'data-car="{stored[2]}"' not in html and "Withdrawn from service (1)" in html
    assert "wheel flat, sent to the shop" in html


def test_fleet_page_pages_a_large_fleet(client: TestClient, session: Session) -> None:
    from service.fleet import review

    keys = build_line(client)
    cars = [f"P{n:03d}" for n in range(review.PAGE_SIZE + 5)]
    for car in cars:
        post_ok(client, "/api/v1/cars", {"id": car})
    load_fleet_history(client, ADMIN, keys["D-bench"], cars, end=END)
    total = len(client.get("/api/v1/maintenance/fleet", headers=ADMIN).json()["cars"])
    assert review.PAGE_SIZE < total <= 2 * review.PAGE_SIZE  # the line's own cars too
    client.post("/review/login", data={"token": ADMIN["Authorization"][7:]})
    first = client.get("/review/fleet").text
    assert first.count("data-car=") == review.PAGE_SIZE and "page 1 of 2" in first
    second = client.get("/review/fleet?page=2").text
    assert second.count("data-car=") == total - review.PAGE_SIZE and "← previous" in second
