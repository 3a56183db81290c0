"""Maintenance API: measurements, parameter bands, forecasts, the fleet ranking, overrides."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Body, Query
from fastapi.responses import Response

from core.auth import CurrentEngineer, CurrentReader
from core.database import DbSession, utcnow
from core.errors import NotFound
from service.fleet import service, views
from service.fleet.chart import cached_chart
from service.fleet.forecasts import ForecastOptions, run_forecasts
from service.fleet.models import Forecast, Parameter
from service.fleet.responses import (
    FleetOut,
    ForecastOut,
    ForecastRunOut,
    MeasurementsStored,
    OverrideOut,
    ParameterOut,
)
from service.fleet.rules import plausible_range, refuse_ahead, refuse_implausible, registered
from service.fleet.schemas import ForecastRunIn, MaintenanceDecisionIn, MeasurementIn, ParameterIn
from service.fleet.vectorised import HISTORY
from service.strict_json import StrictJSONRoute

router = APIRouter(tags=["maintenance"], route_class=StrictJSONRoute)
PNG: dict[int | str, dict[str, Any]] = {
    200: {"content": {"image/png": {}}, "description": "the chart"}
}


def _parameter_out(parameter: Parameter) -> dict[str, Any]:
    return {
        "name": parameter.name,
        "nominal": parameter.nominal,
        "tolerance": parameter.tolerance,
        "lower": parameter.nominal - parameter.tolerance,
        "upper": parameter.nominal + parameter.tolerance,
        "unit": parameter.unit,
        "description": parameter.description,
        "plausible_lower": plausible_range(parameter)[0],
        "plausible_upper": plausible_range(parameter)[1],
    }


@router.post(
    "/cars/{car_id}/measurements",
    status_code=201,
    response_model=MeasurementsStored,
    responses={200: {"description": "the same test again: nothing stored"}, 409: {}},
)
def post_measurements(
    car_id: str, body: MeasurementIn, session: DbSession, _: CurrentEngineer, response: Response
) -> dict[str, Any]:
    """A car's test; sent again with the same values it stores nothing (200), with other
    values at the same ``taken_at`` it is refused (409): a test is not silently rewritten."""
    service.require_car(session, car_id)
    refuse_implausible(registered(session), body.values)
    refuse_ahead(body.taken_at, utcnow())
    answer = {"car": car_id, "taken_at": body.taken_at.isoformat()}
    stored = service.store_test(session, car_id, body.taken_at, body.values, source="api")
    if not stored:
        response.status_code = 200
        return {**answer, "measurements": 0, "status": "duplicate"}
    return {**answer, "measurements": stored, "status": "created"}


@router.get("/maintenance/parameters", response_model=list[ParameterOut])
def list_parameters(session: DbSession, _: CurrentReader) -> list[dict[str, Any]]:
    return [_parameter_out(p) for p in service.list_parameters(session)]


@router.post(
    "/maintenance/parameters", status_code=201, response_model=ParameterOut, responses={409: {}}
)
def create_parameter(body: ParameterIn, session: DbSession, _: CurrentEngineer) -> dict[str, Any]:
    return _parameter_out(service.create_parameter(session, body))


@router.put("/maintenance/parameters/{name}", response_model=ParameterOut)
def update_parameter(
    name: str, body: ParameterIn, session: DbSession, _: CurrentEngineer
) -> dict[str, Any]:
    return _parameter_out(service.update_parameter(session, name, body))


@router.post("/maintenance/forecasts", status_code=201, response_model=ForecastRunOut)
def compute_forecasts(
    session: DbSession, _: CurrentEngineer, body: ForecastRunIn | None = Body(default=None)
) -> dict[str, Any]:
    """Recompute every car's forecast now from the stored history (also ``depot forecast``)."""
    options = ForecastOptions(**(body or ForecastRunIn()).model_dump())
    run = run_forecasts(session, options)
    return {
        "computed_at": run.computed_at.isoformat(),
        "cars": run.cars,
        "statuses": run.statuses,
        "calibration": run.calibration,
        "highest_risk": [{"car": car, "risk": risk} for car, risk in run.top],
    }


def _latest(session: DbSession, car_id: str) -> Forecast:
    service.require_car(session, car_id)
    forecast = views.latest_forecast(session, car_id)
    if forecast is None:
        raise NotFound(
            f"car {car_id!r} has no forecast yet; run POST /api/v1/maintenance/forecasts"
            " (or depot forecast)"
        )
    return forecast


HistoryLimit = Annotated[
    int,
    Query(
        ge=1,
        le=HISTORY.maximum,
        description=f"latest index points returned (default {HISTORY.default},"
        f" at most {HISTORY.maximum}; a stored forecast keeps its latest {HISTORY.stored})",
    ),
]


@router.get("/cars/{car_id}/forecast", response_model=ForecastOut)
def get_forecast(
    car_id: str, session: DbSession, _: CurrentReader, limit: HistoryLimit = HISTORY.default
) -> dict[str, Any]:
    return views.forecast_out(session, _latest(session, car_id), limit)


@router.get("/cars/{car_id}/forecast.png", response_class=Response, responses=PNG)
def get_forecast_chart(car_id: str, session: DbSession, _: CurrentReader) -> Response:
    forecast = _latest(session, car_id)
    key = (forecast.id, forecast.car_id, forecast.computed_at.isoformat())
    png = cached_chart(key, views.forecast_out(session, forecast, HISTORY.maximum))
    return Response(png, media_type="image/png", headers={"Cache-Control": "private, max-age=60"})


@router.get("/maintenance/fleet", response_model=FleetOut)
def get_fleet(session: DbSession, _: CurrentReader) -> dict[str, Any]:
    return views.fleet_out(session)


@router.post("/cars/{car_id}/maintenance-decision", status_code=201, response_model=OverrideOut)
def decide_car(
    car_id: str, body: MaintenanceDecisionIn, session: DbSession, who: CurrentEngineer
) -> dict[str, Any]:
    record = service.record_override(session, car_id, body.action, body.reason, who, utcnow())
    return views.override_out(record, views.latest_forecast(session, car_id))
