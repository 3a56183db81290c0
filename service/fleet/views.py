"""JSON views of forecasts, the fleet ranking and overrides (shared by the API and the page)."""

from __future__ import annotations

from datetime import datetime, timedelta
from typing import Any

from sqlalchemy import func, select
from sqlalchemy.orm import Session

from service.fleet import verdict
from service.fleet.models import Forecast, MaintenanceOverride
from service.fleet.service import latest_overrides, overrides_of
from service.fleet.vectorised import HISTORY

__all__ = ["HISTORY"]


def out_now(forecast: Forecast) -> bool:
    """Whether the car is already out of its band: its index, or a parameter's tolerance."""
    payload = forecast.payload or {}
    return bool(payload.get("out_of_band_now") or payload.get("out_of_tolerance_now"))


def recommendation(forecast: Forecast) -> str:
    """``plan_withdrawal``, ``inspect``, ``watch``, ``serviceable`` or ``unknown`` (no usable
    forecast): :func:`service.fleet.verdict.recommend`."""
    return verdict.recommend(forecast.status, forecast.risk, forecast.payload or {})


def rank_key(forecast: Forecast) -> tuple[Any, ...]:
    """:func:`service.fleet.verdict.rank_key`: out of band first, then the most severe
    recommendation, then risk, then the earliest exit; unknown last."""
    return verdict.rank_key(forecast.status, forecast.risk, forecast.payload or {})


def latest_forecast(session: Session, car_id: str) -> Forecast | None:
    query = select(Forecast).where(Forecast.car_id == car_id).order_by(Forecast.id.desc())
    return session.scalars(query.limit(1)).first()


def latest_forecasts(session: Session) -> list[Forecast]:
    """Each car's newest forecast (forecasts are appended; the latest counts)."""
    newest = select(func.max(Forecast.id)).group_by(Forecast.car_id)
    return list(session.scalars(select(Forecast).where(Forecast.id.in_(newest))))


def override_out(record: MaintenanceOverride, forecast: Forecast | None) -> dict[str, Any]:
    return {
        "id": record.id,
        "car": record.car_id,
        "action": record.action,
        "reason": record.reason,
        "actor": record.actor,
        "recorded_at": record.recorded_at.isoformat(),
        # The engineer decided on an older forecast: worth a second look.
        "forecast_since": forecast is not None and forecast.computed_at > record.recorded_at,
    }


def _clock(payload: dict[str, Any]) -> Any:
    start = datetime.fromisoformat(payload["start"]) if payload.get("start") else None

    def at(days: float | None) -> str | None:
        if start is None or days is None:
            return None
        return (start + timedelta(days=days)).isoformat()

    return at


def _index_forecast(payload: dict[str, Any]) -> dict[str, Any] | None:
    fc = payload.get("forecast")
    if not fc:
        return None
    at = _clock(payload)
    steps = [
        {"step": i + 1, "at": at(t), "value": v, "lower": lo, "upper": hi}
        for i, (t, v, lo, hi) in enumerate(
            zip(fc["times"], fc["values"], fc["lower"], fc["upper"], strict=True)
        )
    ]
    return {"level": fc.get("level"), "steps": steps}


def summary_out(forecast: Forecast, override: MaintenanceOverride | None) -> dict[str, Any]:
    """What the fleet view shows of one car."""
    p = forecast.payload
    index_fc = _index_forecast(p)
    exit_step = p.get("first_exit")
    first_exit = None
    if exit_step is not None and index_fc is not None:
        first_exit = {"step": exit_step, "at": index_fc["steps"][exit_step - 1]["at"]}
    advice = recommendation(forecast)
    return {
        "car": forecast.car_id,
        "forecast_id": forecast.id,
        "computed_at": forecast.computed_at.isoformat(),
        "status": forecast.status,
        "risk": forecast.risk,
        "recommendation": advice,
        "decision": override.action if override is not None else advice,
        "first_exit": first_exit,
        "out_of_band_now": out_now(forecast),
        "out_of_tolerance_now": list(p.get("out_of_tolerance_now") or []),
        "k_of_l_probability": p.get("k_of_l_probability"),
        "index_risk": p.get("index_risk", forecast.risk),
        "parameter_risk": verdict.parameter_risk(p) if forecast.status == "ok" else None,
        "probabilities_calibrated": p.get("probabilities_calibrated"),
        "unvarying": list(p.get("unvarying") or []),
        "reasons": p.get("reasons", []),
        "weights": p.get("weights", {}),
        "contributions": p.get("contributions", {}),
        "override": None if override is None else override_out(override, forecast),
    }


def forecast_out(
    session: Session, forecast: Forecast, limit: int = HISTORY.default
) -> dict[str, Any]:
    """The car's latest forecast, its latest ``limit`` index points, its overrides (newest
    first)."""
    p = forecast.payload
    times, index = p.get("times", [])[-limit:], p.get("index", [])[-limit:]
    records = overrides_of(session, forecast.car_id)
    at = _clock(p)
    units = p.get("units", {})
    return {
        **summary_out(forecast, records[0] if records else None),
        "method": p.get("method"),
        "calibration": p.get("calibration"),
        "n_measurements": p.get("n_measurements", 0),
        "horizon": p.get("horizon"),
        "failure_k": p.get("failure_k"),
        "index_band": p.get("index_band"),
        # Without enough history the index is empty while the test times are listed.
        "index_history": [{"at": at(t), "index": y} for t, y in zip(times, index, strict=False)],
        "index_history_total": p.get("n_measurements", 0),
        "index_history_stored": len(p.get("index") or p.get("times") or []),
        "forecast": _index_forecast(p),
        "parameter_exit_probability": p.get("parameter_exit_probability", {}),
        "bands": {
            name: {"lower": lo, "upper": hi, "unit": units.get(name, "")}
            for name, (lo, hi) in p.get("bands", {}).items()
        },
        "overrides": [override_out(r, forecast) for r in records],
    }


def fleet_out(session: Session) -> dict[str, Any]:
    """Cars in service ranked by risk (highest first), each with its weights, contributions and
    override; cars an engineer withdrew leave the ranking and are listed apart."""
    forecasts = sorted(latest_forecasts(session), key=lambda f: (rank_key(f), f.car_id))
    overrides = latest_overrides(session)
    summaries = [summary_out(f, overrides.get(f.car_id)) for f in forecasts]
    in_service = [c for c in summaries if c["decision"] != "withdraw_now"]
    cars = [{"rank": rank, **c} for rank, c in enumerate(in_service, start=1)]
    latest = max((f.computed_at for f in forecasts), default=None)
    withdrawn = [c for c in summaries if c["decision"] == "withdraw_now"]
    return {
        "computed_at": latest.isoformat() if latest else None,
        "cars": cars,
        "withdrawn": withdrawn,
    }
