"""Trials and exceedance bounds for rare errors (seed ``001``, eq. 8 and Table 1).

Re-exported by :mod:`motion.braking`; see there for the paper's context.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

#: SIL-4 dangerous failure rate used in the paper's text.
SIL4 = 1e-8

#: Table 1 as printed: (p_max, β) → n.
PAPER_TABLE1: dict[tuple[float, float], int] = {
    (1e-2, 0.9): 229,
    (1e-2, 0.99): 459,
    (1e-2, 0.999): 688,
    (1e-4, 0.9): 23025,
    (1e-4, 0.99): 46050,
    (1e-4, 0.999): 69075,
    (1e-6, 0.9): 2302534,
    (1e-6, 0.99): 4605168,
    (1e-6, 0.999): 6907752,
}


def _check_prob(name: str, p: float, *, open_right: bool = True) -> None:
    if not (0.0 < p < 1.0) if open_right else not (0.0 < p <= 1.0):
        raise ValueError(f"{name} must be in (0, 1)")


def trials_needed(p_max: float, beta: float) -> int:
    """Equation (8): trials without an exceedance needed to claim ``p_max`` at
    confidence ``beta``: ``n = lg(1-β)/lg(1-p_max)``, rounded up.

    Computed with ``log1p`` so that small ``p_max`` stays exact.  Where the
    paper's printed table differs (1e-2/0.9 and 1e-6/0.9) see the module notes.
    """
    _check_prob("p_max", p_max)
    _check_prob("beta", beta)
    n = math.log1p(-beta) / math.log1p(-p_max)
    # Guard against 229.0000000001-style float noise on exact integers.
    rn = round(n)
    if abs(n - rn) < 1e-9 * max(1.0, n):
        return int(rn)
    return math.ceil(n)


def p_max_for_trials(n: int, beta: float) -> float:
    """Equation (8) solved for p: ``p_max = 1 - (1-β)^(1/n)``."""
    if n < 1:
        raise ValueError("n must be at least 1")
    _check_prob("beta", beta)
    return -math.expm1(math.log1p(-beta) / n)


def exceedance(p_max: float, k: int, channels: int = 1) -> float:
    """Probability that the smallest of ``k`` independent measurements in each
    of ``channels`` independent channels still exceeds ``ΔL_max``:
    ``p_max^(k·channels)`` (2 → 1e-4, 3 → 1e-6, 4 → 1e-8 from 1e-2)."""
    _check_prob("p_max", p_max, open_right=False)
    if k < 1 or channels < 1:
        raise ValueError("k and channels must be at least 1")
    return float(p_max ** (k * channels))


def measurements_needed(p_max: float, target: float, channels: int = 1) -> int:
    """Smallest ``k`` (per channel) with ``exceedance(p_max, k, channels) ≤ target``."""
    _check_prob("p_max", p_max)
    _check_prob("target", target)
    if channels < 1:
        raise ValueError("channels must be at least 1")
    k = math.ceil(math.log(target) / (channels * math.log(p_max)) - 1e-12)
    return max(1, k)


def range_error_bound(
    max_range_m: float, relative_error: float, trials: int, beta: float
) -> tuple[float, float]:
    """The paper's example: errors never above ``relative_error`` of the range
    in ``trials`` trials, ranges up to ``max_range_m`` → ``(ΔL_max, p_max)``.
    (2 km, 20 %, 459 trials, β = 0.99 → 400 m at p ≤ 1e-2.)"""
    return max_range_m * relative_error, p_max_for_trials(trials, beta)


@dataclass(frozen=True)
class TrialsCell:
    p_max: float
    beta: float
    computed: int
    printed: int

    @property
    def matches(self) -> bool:
        return self.computed == self.printed


def table1() -> list[TrialsCell]:
    """Table 1 of the paper: every cell computed with :func:`trials_needed`
    beside the printed value."""
    return [
        TrialsCell(p, b, trials_needed(p, b), printed) for (p, b), printed in PAPER_TABLE1.items()
    ]
