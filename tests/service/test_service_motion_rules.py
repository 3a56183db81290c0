"""A ``motion_sample`` is either refused with 422 or applied to the train's filter.

The rules are written once (``motion.samples.SAMPLE_LIMITS``,
``sample_problem``) and used by the API schema and by the fusion filter.
Before they were, a GNSS speed of exactly 200 m/s or a ``gnss_lat`` without
``gnss_lon`` was answered 201 and then never applied.  Every rule is tried
here through the real event API; a property test shows that any sample the
schema accepts is applied by the filter, and that the two refuse the same
samples.
"""

from __future__ import annotations

import json
import math
from typing import Any

import pytest
from fastapi.testclient import TestClient
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ingest.schemas import MotionSample as MotionSampleEvent
from motion.fusion import FilterConfig, Marker, MarkerTable, TrackFilter
from motion.samples import SAMPLE_LIMITS, SampleRuleError, check_sample, sample_problem
from service.trains.handlers import sample_of
from tests.conftest import ADMIN
from tests.service.linekit import build_line
from tests.service.scenario import T0, iso

TRAIN = "2041"


def _event(event_id: str, **fields: Any) -> dict[str, Any]:
    return {
        "event_id": event_id,
        "occurred_at": iso(T0),
        "kind": "motion_sample",
        "train": TRAIN,
        "t": 0.0,
        "accel_mps2": 0.1,
        **fields,
    }


def _post_raw(client: TestClient, headers: dict[str, str], body: str) -> Any:
    """Posted as text: ``NaN`` and ``Infinity`` are not JSON, but Python's
    parser (and some device firmware) produce them."""
    return client.post(
        "/api/v1/events",
        content=body.encode(),
        headers={**headers, "Content-Type": "application/json"},
    )


# (event fields, the field the 422 must name)
REFUSED = [
    pytest.param({"gnss_speed_mps": 200.0}, "gnss_speed_mps", id="speed-200-m/s"),
    pytest.param({"gnss_speed_mps": 250.0}, "gnss_speed_mps", id="speed-over-range"),
    pytest.param({"gnss_speed_mps": -0.5}, "gnss_speed_mps", id="speed-negative"),
    pytest.param({"gnss_lat": 50.45}, "gnss_lon", id="lat-without-lon"),
    pytest.param({"gnss_lon": 30.52}, "gnss_lat", id="lon-without-lat"),
    pytest.param({"gnss_lat": 90.5, "gnss_lon": 30.52}, "gnss_lat", id="lat-over-90"),
    pytest.param({"gnss_lat": -91.0, "gnss_lon": 30.52}, "gnss_lat", id="lat-under-minus-90"),
    pytest.param({"gnss_lat": 50.45, "gnss_lon": 180.5}, "gnss_lon", id="lon-over-180"),
    pytest.param({"gnss_lat": 50.45, "gnss_lon": -181.0}, "gnss_lon", id="lon-under-minus-180"),
    pytest.param({"accel_mps2": 50.5}, "accel_mps2", id="accel-over-5-g"),
    pytest.param({"gnss_speed_mps": 3.0, "gnss_delay_s": 601.0}, "gnss_delay_s", id="delay"),
    pytest.param({"gnss_speed_mps": 3.0, "gnss_delay_s": -1.0}, "gnss_delay_s", id="delay-neg"),
]


@pytest.mark.parametrize(("fields", "field"), REFUSED)
def test_a_sample_breaking_a_rule_is_refused_and_not_stored(
    client: TestClient, fields: dict[str, Any], field: str
) -> None:
    keys = build_line(client)
    response = client.post("/api/v1/events", json=_event("bad", **fields), headers=keys["T-obu"])
    assert response.status_code == 422, response.text
    assert response.headers["content-type"].startswith("application/problem+json")
    problem = response.json()
    assert field in problem["detail"], problem
    assert any(e["loc"][-1] == field for e in problem["errors"]), problem
    # nothing was applied, and the event_id is free: the corrected sample is new
    assert client.get(f"/api/v1/trains/{TRAIN}/position", headers=ADMIN).status_code == 404
    fixed = client.post("/api/v1/events", json=_event("bad"), headers=keys["T-obu"])
    assert fixed.status_code == 201, fixed.text


NON_FINITE = [
    pytest.param(field, token, id=f"{field}={token}")
    for field in ("t", "accel_mps2", "gnss_speed_mps", "gnss_delay_s", "gnss_lat", "gnss_lon")
    for token in ("NaN", "Infinity", "-Infinity")
]


@pytest.mark.parametrize(("field", "token"), NON_FINITE)
def test_non_finite_values_are_refused(client: TestClient, field: str, token: str) -> None:
    keys = build_line(client)
    body = _event("nan", gnss_speed_mps=3.0, gnss_delay_s=1.0, gnss_lat=50.45, gnss_lon=30.52)
    body[field] = "__VALUE__"
    response = _post_raw(client, keys["T-obu"], json.dumps(body).replace('"__VALUE__"', token))
    assert response.status_code == 422, response.text
    assert field in response.json()["detail"]
    assert client.get(f"/api/v1/trains/{TRAIN}/position", headers=ADMIN).status_code == 404


def test_samples_at_the_limits_are_applied(client: TestClient) -> None:
    """The edges of every range are valid samples, and they move the filter."""
    keys = build_line(client)
    lim = SAMPLE_LIMITS
    edges: list[dict[str, Any]] = [
        {"accel_mps2": lim.max_abs_accel_mps2},
        {"accel_mps2": -lim.max_abs_accel_mps2},
        {"gnss_speed_mps": math.nextafter(lim.max_gnss_speed_mps, 0.0), "gnss_delay_s": 0.0},
        {"gnss_speed_mps": 0.0, "gnss_delay_s": lim.max_gnss_delay_s},
        {"gnss_lat": lim.max_abs_lat_deg, "gnss_lon": -lim.max_abs_lon_deg},
        {"gnss_lat": -lim.max_abs_lat_deg, "gnss_lon": lim.max_abs_lon_deg},
        {"marker_id": "not-on-this-line"},
    ]
    for k, fields in enumerate(edges):
        t = 0.1 * k
        response = client.post(
            "/api/v1/events", json=_event(f"edge-{k}", t=t, **fields), headers=keys["T-obu"]
        )
        assert response.status_code == 201, response.text
        result = response.json()
        assert result["position"] is not None and "warning" not in result, result
        position = client.get(f"/api/v1/trains/{TRAIN}/position", headers=ADMIN).json()
        assert position["t"] == pytest.approx(t)


# -- the schema and the filter agree -------------------------------------------------

_FLOATS = st.one_of(
    st.none(),
    st.floats(allow_nan=True, allow_infinity=True),
    st.floats(min_value=-300.0, max_value=700.0),
    st.sampled_from([0.0, -0.0, 50.0, -50.0, 90.0, -90.0, 180.0, -180.0, 199.99, 200.0, 600.0]),
)


@st.composite
def _candidate(draw: st.DrawFn) -> dict[str, Any]:
    """Mostly plausible, often just over a limit, sometimes absurd."""
    body: dict[str, Any] = {
        "event_id": "p",
        "occurred_at": iso(T0),
        "kind": "motion_sample",
        "train": TRAIN,
        "t": draw(st.one_of(st.floats(min_value=0.0, max_value=1e6), _FLOATS)),
        "accel_mps2": draw(st.one_of(st.floats(min_value=-60.0, max_value=60.0), _FLOATS)),
    }
    for name in ("gnss_speed_mps", "gnss_delay_s", "gnss_lat", "gnss_lon"):
        value = draw(_FLOATS)
        if value is not None:
            body[name] = value
    if draw(st.booleans()):
        body["marker_id"] = draw(st.sampled_from(["M0", "M1", "elsewhere"]))
    return body


def _line() -> MarkerTable:
    return MarkerTable(
        [Marker("M0", 0.0, 50.45, 30.52), Marker("M1", 1500.0, 50.45, 30.541)],
        sections=[("AB", 0.0, 1500.0)],
    )


def _schema_accepts(body: dict[str, Any]) -> MotionSampleEvent | None:
    try:
        return MotionSampleEvent.model_validate(body)
    except ValueError:  # pydantic's ValidationError
        return None


@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(body=_candidate())
def test_every_sample_the_schema_accepts_is_applied(body: dict[str, Any]) -> None:
    event = _schema_accepts(body)
    if body["t"] is None or body["accel_mps2"] is None:
        assert event is None  # both are required numbers
        return
    t, accel = float(body["t"]), float(body["accel_mps2"])
    optional = [body.get(k) for k in ("gnss_speed_mps", "gnss_delay_s", "gnss_lat", "gnss_lon")]
    speed, delay, lat, lon = optional
    problem = sample_problem(t, accel, speed, delay, lat, lon)
    # one rule set: the schema refuses exactly what the rules refuse
    assert (event is None) == (problem is not None), (body, problem)
    if event is None:
        with pytest.raises(SampleRuleError):
            check_sample(t, accel, speed, delay, lat, lon)
        return
    # ... and what it accepts, the filter applies (a new train, and one already running)
    for prior in ((), (body["t"] - 1.0,)):
        f = TrackFilter(_line(), FilterConfig(initial_position_m=0.0))
        for t0 in prior:
            f.step(t0, 0.0)
        state = f.update(sample_of(event))
        assert state.t == body["t"]
        assert math.isfinite(state.position_m) and math.isfinite(state.sigma_position_m)
