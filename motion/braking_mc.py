"""Monte Carlo study of the braking-distance error with the speed error of
equation (9), ``ΔV = 0.1·V·(rnd(2) - 1)`` (seed ``001``).

Re-exported by :mod:`motion.braking`; see there for the paper's context.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any, Literal

import numpy as np

from .braking_limits import BRAKING_LIMITS, check_range
from .pearson import PearsonI, fit_pearson1
from .protective import G
from .trials import p_max_for_trials, trials_needed


@dataclass(frozen=True)
class MonteCarloResult:
    """Braking-distance errors ``ΔS = S_nominal - S_actual`` (negative:
    the train needed more room than computed — the dangerous side)."""

    control: str
    runs: int
    speed_mps: float
    nominal_distance_m: float
    errors_m: list[float]
    mean_m: float
    std_m: float
    min_m: float
    max_m: float
    counts: list[int]  # histogram, relative frequency = counts / runs
    edges_m: list[float]
    delta_s_max_m: float  # empirical bound: |most negative error|
    beta: float
    p_exceed: float  # p_max claimable for delta_s_max_m with `runs` trials at `beta`
    trials_for: dict[str, int]  # "1e-02" → trials needed at `beta`
    fit: PearsonI | None
    seed: int
    params: dict[str, float] = field(default_factory=dict)

    def as_dict(self, *, with_errors: bool = False) -> dict[str, Any]:
        d = asdict(self)
        if not with_errors:
            d.pop("errors_m")
        return d


def _simulate_stop(
    v0: float,
    target_m: float,
    control: str,
    rng: np.random.Generator | None,
    p: dict[str, float],
) -> float:
    """One target braking from ``v0`` to stop ``target_m`` ahead.  Returns the
    distance actually run.  ``rng=None`` runs the nominal (error-free) case."""
    dt = p["dt_s"]
    tc = p["control_period_s"]
    tau = p["brake_lag_s"]
    a_nom = p["deceleration_mps2"]
    a_max = p["max_deceleration_mps2"]
    kv = p["speed_gain_per_s"]
    w0, w1, w2 = p["res_a0"], p["res_a1"], p["res_a2"]
    if rng is not None:
        res_scale = 1.0 + rng.uniform(-p["res_dev"], p["res_dev"])
        grade = G * rng.uniform(-p["grade_dev_permille"], p["grade_dev_permille"]) / 1000.0
    else:
        res_scale, grade = 1.0, 0.0
    v, s, a_brake = v0, 0.0, 0.0
    s_hat = 0.0
    a_cmd = 0.0
    steps_per_ctl = max(1, round(tc / dt))
    step = 0
    v_meas = v0
    while v > 0.0 and step < 200000:
        if step % steps_per_ctl == 0:
            v_meas = v
            if rng is not None:
                v_meas = v + 0.1 * v * (rng.uniform(0.0, 2.0) - 1.0)  # eq. (9)
            d_rem = target_m - s_hat
            if control == "deceleration":
                a_cmd = v_meas**2 / (2 * d_rem) if d_rem > 0.05 else a_max
            else:  # speed: follow the reference curve V_ref(d) = √(2·a_nom·d)
                v_ref = math.sqrt(2 * a_nom * max(d_rem, 0.0))
                a_cmd = a_nom + kv * (v_meas - v_ref)
                if d_rem <= 0.05:
                    a_cmd = a_max
            a_cmd = min(max(a_cmd, 0.0), a_max)
        a_brake += (a_cmd - a_brake) * dt / tau
        resist = res_scale * (w0 + w1 * v + w2 * v * v)
        acc = -(a_brake + resist + grade)
        v_new = v + acc * dt
        if v_new <= 0.0:
            frac = v / (v - v_new) if v != v_new else 1.0
            s += v * frac * dt / 2
            break
        s += (v + v_new) / 2 * dt
        s_hat += v_meas * dt  # odometer integrates the measured speed
        v = v_new
        step += 1
    return s


_MC_DEFAULTS: dict[str, float] = {
    "dt_s": 0.02,
    "control_period_s": 0.2,
    "brake_lag_s": 0.5,
    "deceleration_mps2": 0.7,
    "max_deceleration_mps2": 1.2,
    "speed_gain_per_s": 0.8,
    "res_a0": 0.01,  # running resistance a0 + a1·v + a2·v², m/s²
    "res_a1": 3e-4,
    "res_a2": 3e-5,
    "res_dev": 0.2,  # per-run relative deviation of the resistance
    "grade_dev_permille": 0.5,  # per-run profile error
}


def braking_error_monte_carlo(
    runs: int = 230,
    *,
    control: Literal["deceleration", "speed"] = "deceleration",
    speed_mps: float = 16.7,
    beta: float = 0.9,
    bins: int = 15,
    seed: int = 0,
    **params: float,
) -> MonteCarloResult:
    """Monte Carlo study of the braking-distance error with the speed error of
    equation (9), ``ΔV = 0.1·V·(rnd(2) - 1)``, drawn anew at every control
    period of a target-braking controller.

    ``control="deceleration"`` commands ``a = V̂²/(2·d̂)`` from the measured
    speed V̂ and the remaining distance d̂ (odometer on V̂);
    ``control="speed"`` tracks the reference curve ``V_ref(d̂) = √(2·a·d̂)``.
    The nominal braking distance is the same simulation without errors; the
    error is ``ΔS = S_nominal - S_actual``.  Model parameters (``params``)
    default to :data:`_MC_DEFAULTS`.

    The empirical bound is ``ΔS_max = |min ΔS|``; with ``runs`` trials and no
    larger error seen, it is exceeded with probability at most
    ``p_exceed = 1 - (1-β)^(1/runs)`` at confidence β.
    """
    if control not in ("deceleration", "speed"):
        raise ValueError("control must be 'deceleration' or 'speed'")
    lim = BRAKING_LIMITS
    if runs < lim.min_monte_carlo_runs or runs > lim.max_monte_carlo_runs:
        raise ValueError(
            f"runs must be a whole number in [{lim.min_monte_carlo_runs},"
            f" {lim.max_monte_carlo_runs}] (got {runs}): a bound needs at least two brakings"
        )
    check_range("speed", speed_mps, 0.0, BRAKING_LIMITS.max_speed_mps, "m/s", low_open=True)
    unknown = set(params) - set(_MC_DEFAULTS)
    if unknown:
        raise ValueError(f"unknown model parameters: {sorted(unknown)}")
    p = {**_MC_DEFAULTS, **{k: float(v) for k, v in params.items()}}
    target = speed_mps**2 / (2 * p["deceleration_mps2"])
    nominal = _simulate_stop(speed_mps, target, control, None, p)
    rng = np.random.default_rng(seed)
    errs = np.array(
        [nominal - _simulate_stop(speed_mps, target, control, rng, p) for _ in range(runs)]
    )
    counts, edges = np.histogram(errs, bins=bins)
    dmax = max(0.0, -float(errs.min()))
    return MonteCarloResult(
        control=control,
        runs=runs,
        speed_mps=speed_mps,
        nominal_distance_m=nominal,
        errors_m=errs.tolist(),
        mean_m=float(errs.mean()),
        std_m=float(errs.std(ddof=1)),
        min_m=float(errs.min()),
        max_m=float(errs.max()),
        counts=[int(c) for c in counts],
        edges_m=[float(e) for e in edges],
        delta_s_max_m=dmax,
        beta=beta,
        p_exceed=p_max_for_trials(runs, beta),
        trials_for={f"{q:.0e}": trials_needed(q, beta) for q in (1e-2, 1e-4, 1e-6)},
        fit=fit_pearson1(errs),
        seed=seed,
        params=p,
    )
