"""A forecast's consequence: the recommendation, the risk it rests on, and the fleet order.

The spec (maintenance.md) gives three pieces of evidence and does not say how they combine:

- the **index**: the car is watched until its quality index leaves its band (fig. 4.1), and the
  risk of the index forecast leaving it within the horizon;
- the **K-of-L failure criterion**: at least K of the L predictive parameters out of tolerance,
  its probability at the horizon from the per-parameter forecasts;
- each **parameter's own forecast** of leaving its tolerance band at the horizon.

The spec's two failure probabilities make the car's ``risk``: the larger of the index risk and
the K-of-L probability (``plan_withdrawal`` from ``withdraw_risk``, ``watch`` from
``watch_risk``). Where the spec is silent — one parameter forecast out of its band while fewer
than K are — the service takes the most severe verdict: the index fitted on a car's own history
can give a drifting parameter next to no weight, so the index alone may say "serviceable" while
the parameter's forecast says it leaves its band; such a car is at least ``watch``
(``parameter_risk``, the largest parameter exit probability, from ``withdraw_risk``), and the
reasons say which verdict decided. The fleet ranks by recommendation first, then risk, so the
ranking never puts a less severe car above a more severe one. Evidence that cannot carry a
probability — a parameter that did not vary at all over its recent tests (a stuck sensor, or
one value carried forward) — asks a person to look (``inspect``), never a confident
"serviceable".

Probabilities from these Gaussian models are never certainties: they are shown clipped to
``[probability_floor, 1 − probability_floor]`` and marked uncalibrated when the fleet index band
was not calibrated from the depot's records.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray


@dataclass(frozen=True)
class VerdictRules:
    """Tunables of the forecast's consequence (one place; README "Maintenance forecasts").

    Attributes
    ----------
    withdraw_risk : float
        At this risk (the index leaving its band, or the K-of-L failure, within the horizon)
        the car is planned out of service (``plan_withdrawal``): even odds, the package flags
        at the same risk. One parameter forecast out of its band at this probability makes
        the car at least ``watch`` (the spec's failure needs K of them).
    watch_risk : float
        At this risk the car is looked at on its next depot visit (``watch``).
    probability_floor : float
        Model probabilities are shown in ``[floor, 1 − floor]``: a Gaussian tail of 1e-62 is
        not evidence of anything, and 0 or 1 would read as certainty.
    stuck_min_tests : int
        A parameter with no variation at all over at least this many of its latest tests
        (up to ``stuck_window``) makes the car ``inspect``: real readings always scatter.
    stuck_window : int
        How many latest tests the no-variation check looks at (the forecast's window).
    stuck_resolution : float
        "No variation": the readings' range is at most this fraction of the tolerance band.
    """

    withdraw_risk: float = 0.5
    watch_risk: float = 0.1
    probability_floor: float = 1e-3
    stuck_min_tests: int = 10
    stuck_window: int = 40
    stuck_resolution: float = 1e-9


RULES = VerdictRules()
# From most to least severe; the fleet ranks in this order (then by risk).
SEVERITY = ("plan_withdrawal", "inspect", "watch", "serviceable", "unknown")


def clipped(p: float | None, rules: VerdictRules = RULES) -> float | None:
    """``p`` kept off 0 and 1 (None and NaN stay unknown)."""
    if p is None or not np.isfinite(p):
        return None
    return float(np.clip(p, rules.probability_floor, 1.0 - rules.probability_floor))


def clip_probabilities(payload: dict[str, Any], rules: VerdictRules = RULES) -> None:
    """Clip every model probability of an ``ok`` payload in place."""
    payload["risk"] = clipped(payload.get("risk"), rules)
    payload["k_of_l_probability"] = clipped(payload.get("k_of_l_probability"), rules)
    exits = payload.get("parameter_exit_probability") or {}
    payload["parameter_exit_probability"] = {k: clipped(v, rules) for k, v in exits.items()}


def unvarying(
    names: Sequence[str], values: NDArray[np.float64], limits: NDArray[np.float64],
    rules: VerdictRules = RULES,
) -> tuple[int, list[str]]:  # fmt: skip
    """How many latest tests were checked and the parameters that did not vary over them."""
    recent = values[-rules.stuck_window :]
    n = int(recent.shape[0])
    if n < rules.stuck_min_tests or not names:
        return n, []
    span = np.ptp(recent, axis=0)
    still = span <= rules.stuck_resolution * (limits[:, 1] - limits[:, 0])
    return n, [names[int(j)] for j in np.flatnonzero(still)]


def combined_risk(risk: float | None, payload: Mapping[str, Any]) -> float | None:
    """The larger of the index risk and the K-of-L failure probability (None when the index
    risk is unknown: no usable forecast)."""
    if risk is None:
        return None
    k_of_l = payload.get("k_of_l_probability")
    return max(risk, k_of_l) if k_of_l is not None else risk


def parameter_risk(payload: Mapping[str, Any]) -> float | None:
    """The largest probability of one parameter leaving its tolerance band (None: none)."""
    exits = [p for p in (payload.get("parameter_exit_probability") or {}).values() if p is not None]
    return max(exits) if exits else None


def recommend(
    status: str, risk: float | None, payload: Mapping[str, Any], rules: VerdictRules = RULES
) -> str:
    """``plan_withdrawal``, ``inspect``, ``watch``, ``serviceable`` or ``unknown``.

    A car already out of its band is planned out whatever its forecast (a person must look),
    even when the forecast failed or the index band was not calibrated; a parameter that did
    not vary asks for a person (``inspect``) unless something already plans the car out.
    """
    if payload.get("out_of_band_now") or payload.get("out_of_tolerance_now"):
        return "plan_withdrawal"
    risk = combined_risk(risk, payload) if status == "ok" else None
    if status == "ok" and (payload.get("first_exit") is not None or (
        risk is not None and risk >= rules.withdraw_risk
    )):  # fmt: skip
        return "plan_withdrawal"
    if payload.get("unvarying"):
        return "inspect"
    if risk is None:
        return "unknown"
    single = parameter_risk(payload) if status == "ok" else None
    if risk >= rules.watch_risk or (single is not None and single >= rules.withdraw_risk):
        return "watch"
    return "serviceable"


def rank_key(status: str, risk: float | None, payload: Mapping[str, Any]) -> tuple[Any, ...]:
    """Cars already out of their band first; then by recommendation (most severe first), then
    the risk (highest first), then the earliest index exit; unknown last."""
    first = 0 if payload.get("out_of_band_now") or payload.get("out_of_tolerance_now") else 1
    level = SEVERITY.index(recommend(status, risk, payload))
    risk = combined_risk(risk, payload) if status == "ok" else None
    single = parameter_risk(payload) if status == "ok" else None
    exit_step = payload.get("first_exit")
    ahead = float(exit_step) if exit_step is not None else float("inf")
    return (first, level, -(risk if risk is not None else -1.0), -(single or 0.0), ahead)


def judge(
    payload: dict[str, Any],
    names: Sequence[str],
    values: NDArray[np.float64],
    limits: NDArray[np.float64],
    *,
    calibrated: bool,
    horizon: int,
    failure_k: int,
    rules: VerdictRules = RULES,
) -> float | None:
    """Give an ``ok`` payload its combined ``risk``, ``index_risk``, evidence flags and reasons;
    returns the car's risk (None: the evidence carries no probability)."""
    clip_probabilities(payload, rules)
    index_risk = payload["risk"]
    payload["index_risk"] = index_risk
    payload["probabilities_calibrated"] = calibrated
    first: list[str] = []
    n, still = unvarying(names, values, limits, rules)
    payload["unvarying"] = still
    if still:
        first.append(
            f"no variation in {n} tests of {', '.join(still)} — sensor may be stuck (or a value"
            " carried forward): a person must look; no risk is given"
        )
    risk = None if still else combined_risk(index_risk, payload)
    payload["risk"] = risk
    payload["parameter_risk"] = parameter_risk(payload)
    # the index's own verdict stays first (after a stuck sensor), the other verdicts follow it
    index_words, *rest = payload.get("reasons") or [""]
    reasons = [*first, index_words, *_evidence(payload, index_risk, horizon, failure_k, rules)]
    reasons.extend(rest)
    if not calibrated:
        reasons.append(
            "probabilities come from an uncalibrated model (see calibration); shown within"
            f" [{rules.probability_floor:g}, {1 - rules.probability_floor:g}], not as certainty"
        )
    payload["reasons"] = [r for r in reasons if r]
    return risk


def _evidence(
    payload: Mapping[str, Any], index_risk: float | None, horizon: int, failure_k: int,
    rules: VerdictRules,
) -> list[str]:  # fmt: skip
    exits = {k: v for k, v in (payload.get("parameter_exit_probability") or {}).items() if v}
    leaving = sorted(((p, k) for k, p in exits.items() if p >= rules.watch_risk), reverse=True)
    k_of_l = payload.get("k_of_l_probability")
    if not leaving and (k_of_l is None or k_of_l < rules.watch_risk):
        return []
    out = []
    if leaving:
        listed = ", ".join(f"{k} {p:.1%}" for p, k in leaving)
        out.append(f"parameter forecast out of its tolerance band within {horizon} tests: {listed}")
    total = len(exits)
    index_words = "unknown" if index_risk is None else f"{index_risk:.1%}"
    out.append(
        f"recommendation from the most severe of: index forecast (risk {index_words}),"
        f" K-of-L failure (at least {min(failure_k, total)} of {total} parameters out:"
        f" {(k_of_l or 0.0):.1%}) and the single-parameter forecasts (largest"
        f" {max(exits.values(), default=0.0):.1%}; one parameter leaving its band is at least"
        f" watch from {rules.withdraw_risk:.0%})"
    )
    return out
