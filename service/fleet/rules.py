"""The one rule for measured values, used by the engineer API, ``measurement`` events and the
CSV import: a value must name a registered parameter and lie in its plausible range.

A value far outside any band is a broken sensor, a unit slip (ms for s) or a typo — not wear —
and one such value would push its car to certain failure and move the fleet's calibration,
so it is refused with the reason rather than stored.
"""

from __future__ import annotations

import difflib
from collections.abc import Mapping
from dataclasses import dataclass
from datetime import datetime, timedelta

from sqlalchemy import select
from sqlalchemy.orm import Session

from core.errors import Unprocessable
from core.schemas import format_instant
from core.settings import get_settings
from service.fleet.models import Parameter


@dataclass(frozen=True)
class MeasurementRules:
    """Tunables of the plausibility rule.

    Attributes
    ----------
    plausible_tolerances : float
        Where the engineer set no plausible range, values farther than this many tolerances
        from the nominal value are refused (a car in the band's tail is 1–3 tolerances out).
    non_negative_units : frozenset of str
        Units of quantities that are never negative (durations, resistances): without the
        engineer's ``plausible_lower`` the default range starts at 0, not below it.
    """

    plausible_tolerances: float = 10.0
    non_negative_units: frozenset[str] = frozenset(
        {"s", "ms", "min", "h", "Ohm", "ohm", "kOhm", "MOhm", "GOhm", "Ω", "kΩ", "MΩ", "GΩ"}
    )


RULES = MeasurementRules()


def plausible_range(parameter: Parameter, rules: MeasurementRules = RULES) -> tuple[float, float]:
    """``(lower, upper)`` a value of ``parameter`` must lie in: the engineer's, else nominal ±
    ``plausible_tolerances`` tolerances, never below 0 for a non-negative unit (s, Ω)."""
    span = rules.plausible_tolerances * parameter.tolerance
    lower = parameter.plausible_lower
    upper = parameter.plausible_upper
    if lower is None:
        lower = parameter.nominal - span
        if parameter.unit in rules.non_negative_units:
            lower = max(0.0, lower)
    return (lower, parameter.nominal + span if upper is None else upper)


def registered(session: Session) -> dict[str, Parameter]:
    return {p.name: p for p in session.scalars(select(Parameter))}


def value_problems(
    parameters: Mapping[str, Parameter], values: Mapping[str, float]
) -> dict[str, str]:
    """Each refused value's parameter name → the reason, in words that name the fix."""
    problems: dict[str, str] = {}
    for name, value in values.items():
        parameter = parameters.get(name)
        if parameter is None:
            close = difflib.get_close_matches(name, list(parameters), n=1)
            hint = f"did you mean {close[0]!r}? " if close else ""
            problems[name] = (
                f"{name!r} is not a registered parameter; {hint}register its band with"
                " POST /api/v1/maintenance/parameters"
            )
            continue
        lower, upper = plausible_range(parameter)
        if not lower <= value <= upper:
            unit = f" {parameter.unit}" if parameter.unit else ""
            problems[name] = (
                f"{name} = {value:g}{unit} is outside its plausible range"
                f" {lower:g}…{upper:g}{unit} (check the sensor and the unit)"
            )
    return problems


def refuse_implausible(parameters: Mapping[str, Parameter], values: Mapping[str, float]) -> None:
    """Raise 422 naming every refused value (nothing of the test is stored then)."""
    problems = value_problems(parameters, values)
    if problems:
        errors = [{"loc": ["body", "values", k], "msg": v} for k, v in problems.items()]
        raise Unprocessable("; ".join(problems.values()), errors=errors)


def ahead_problem(taken_at: datetime, now: datetime) -> str | None:
    """Why a test dated ``taken_at`` is refused at server time ``now``, or None: the same
    allowed clock skew as device events (``DEPOT_MAX_CLOCK_SKEW_S``, ``ingest.checks``), since
    a test dated ahead would be the car's "latest" state for years and move its forecast."""
    skew = get_settings().max_clock_skew_s
    if taken_at <= now + timedelta(seconds=skew):
        return None
    ahead = (taken_at - now).total_seconds()
    return (
        f"taken_at {format_instant(taken_at)} is {ahead:.0f} s ahead of the server's clock"
        f" ({format_instant(now.replace(microsecond=0))}); at most {skew:g} s is allowed"
        " (DEPOT_MAX_CLOCK_SKEW_S): give the time the test was taken"
    )


def refuse_ahead(taken_at: datetime, now: datetime) -> None:
    """Raise 422 for a test dated further ahead than the allowed clock skew."""
    problem = ahead_problem(taken_at, now)
    if problem:
        raise Unprocessable(problem, errors=[{"loc": ["body", "taken_at"], "msg": problem}])
