"""Braking before an obstacle: protective section and error bounds (seed ``001``,
Baranov, Bestemyanov, Balakina, Okhotnikov 2021).

A vision system measures the distance ``L`` to an obstacle; braking starts
when the computed braking distance equals it, ``S_brake(V) = L_meas`` (1).
Both err.  With protective margins braking starts when
``S_brake(V) + ΔS_max = L_meas - ΔL_max`` (6); the *protective section* is
``ΔS_max + ΔL_max`` and ``P_collision < P(ΔS > ΔS_max)·P(ΔL > ΔL_max)`` (7).

How large may the margins be claimed?  If an error never exceeded a bound in
``n`` independent trials, the largest exceedance probability compatible with
that at confidence β is ``p_max = 1 - (1-β)^(1/n)``; conversely
``n = lg(1-β)/lg(1-p_max)`` (8), rounded up (:func:`trials_needed`).

Table 1 of the paper versus the formula
---------------------------------------
The formula, rounded up as the paper says, gives every printed cell except
two (:data:`PAPER_TABLE1`, :func:`table1`):

* p_max = 1e-2, β = 0.9: the formula gives 229.10…, i.e. **230**; the paper
  prints 229 (rounded down; 229 trials only reach β = 0.8999).
* p_max = 1e-6, β = 0.9: the formula gives 2302583.9…, i.e. **2302584**; the
  paper prints 2302534 (a slipped digit).

The paper's text also asks for "46050 experiments for 1e-4 at confidence
0.9"; its own table gives 23025 for β = 0.9 (46050 is β = 0.99).

Using the **smallest** of ``k`` independent measurements, the chance that
all of them exceed ``ΔL_max`` is ``p_max^k`` (:func:`exceedance`); a second,
wayside channel multiplies the exponent: two measurements in each of two
channels at 1e-2 give 1e-8 (SIL-4).  ``ΔL_max`` then grows by the distance
run during the ``k`` measurements.

The braking-distance error is studied by Monte Carlo with the speed error
``ΔV = 0.1·V·(rnd(2) - 1)`` (9) in the speed feedback of a target-braking
controller (:func:`braking_error_monte_carlo`).  The paper's train models
(suburban trains of its references 15 and 16) are not given; the model here
is a point mass with a first-order brake, a Davis-type running resistance
with a per-run deviation, and an odometer integrating the measured speed.
Its error ranges are of the paper's order (metres), not the paper's figures.

Every calculator refuses inputs outside :data:`BRAKING_LIMITS` (a
``ValueError`` naming the quantity, its unit and the range), so the API and
the CLI refuse the same values.
"""

from __future__ import annotations

from .braking_limits import BRAKING_LIMITS, BrakingLimits
from .braking_mc import MonteCarloResult, braking_error_monte_carlo
from .pearson import PearsonI, fit_pearson1
from .protective import BrakingPlan, ErrorModel, G, braking_distance, braking_plan, max_safe_speed
from .trials import (
    PAPER_TABLE1,
    SIL4,
    TrialsCell,
    exceedance,
    measurements_needed,
    p_max_for_trials,
    range_error_bound,
    table1,
    trials_needed,
)

__all__ = [
    "BRAKING_LIMITS",
    "BrakingLimits",
    "G",
    "PAPER_TABLE1",
    "SIL4",
    "BrakingPlan",
    "ErrorModel",
    "MonteCarloResult",
    "PearsonI",
    "TrialsCell",
    "braking_distance",
    "braking_error_monte_carlo",
    "braking_plan",
    "exceedance",
    "fit_pearson1",
    "max_safe_speed",
    "measurements_needed",
    "p_max_for_trials",
    "range_error_bound",
    "table1",
    "trials_needed",
]
