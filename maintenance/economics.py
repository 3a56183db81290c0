"""Economic effect of predictive maintenance (thesis 4.4).

``ΔE = Σ_t (C1_t − C2_t − K2_t)·α_t``: repair costs without (C1) and with (C2)
the system, the system's own costs (K2) and the discount factor ``α_t`` that
brings year ``t`` to the reference year, ``α_t = (1 + E)^(t_ref − t)``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from maintenance._checks import as_vector


def discount_factors(years: Any, *, reference_year: int, rate: float) -> np.ndarray:
    """``α_t = (1 + rate)^(reference_year − t)`` for each year (rate > −1)."""
    t = as_vector(years, "years")
    if not float(rate) > -1.0:
        raise ValueError(f"rate must be > -1, got {rate!r}")
    return np.asarray((1.0 + float(rate)) ** (int(reference_year) - t), dtype=np.float64)


def economic_effect(
    repair_without: Any, repair_with: Any, system_cost: Any, discount: Any
) -> float:
    """Discounted cumulative effect ``ΔE = Σ_t (C1_t − C2_t − K2_t)·α_t``.

    All arguments have shape (n_years,), in the same currency unit (the thesis
    uses thousand UAH); ``discount`` holds ``α_t``.
    """
    c1 = as_vector(repair_without, "repair_without")
    c2 = as_vector(repair_with, "repair_with")
    k2 = as_vector(system_cost, "system_cost")
    alpha = as_vector(discount, "discount")
    if not c1.shape == c2.shape == k2.shape == alpha.shape:
        raise ValueError(
            "repair_without, repair_with, system_cost and discount need one value per year"
        )
    return float(np.sum((c1 - c2 - k2) * alpha))
