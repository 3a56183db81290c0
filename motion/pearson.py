"""Pearson type I (four-parameter beta) fit by moments with a χ² test, as
the paper fits its braking-error histograms (seed ``001``).

Re-exported by :mod:`motion.braking`; see there for the paper's context.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt


@dataclass(frozen=True)
class PearsonI:
    """Four-parameter beta (Pearson type I) fitted by moments, with a χ² test."""

    alpha: float
    beta: float
    lower: float
    upper: float
    chi2: float
    dof: int
    p_value: float

    def pdf(self, x: npt.ArrayLike) -> npt.NDArray[np.float64]:
        z = (np.asarray(x, dtype=np.float64) - self.lower) / (self.upper - self.lower)
        out = np.zeros_like(z)
        m = (z > 0) & (z < 1)
        lb = math.lgamma(self.alpha) + math.lgamma(self.beta) - math.lgamma(self.alpha + self.beta)
        out[m] = np.exp(
            (self.alpha - 1) * np.log(z[m]) + (self.beta - 1) * np.log1p(-z[m]) - lb
        ) / (self.upper - self.lower)
        return out

    def cdf(self, x: float) -> float:
        z = (x - self.lower) / (self.upper - self.lower)
        return _betainc(self.alpha, self.beta, min(1.0, max(0.0, z)))


def _betacf(a: float, b: float, x: float) -> float:
    # Continued fraction for the incomplete beta function (Lentz).
    tiny = 1e-300
    qab, qap, qam = a + b, a + 1.0, a - 1.0
    c, d = 1.0, 1.0 - qab * x / qap
    d = tiny if abs(d) < tiny else d
    d = 1.0 / d
    h = d
    for m in range(1, 300):
        m2 = 2 * m
        aa = m * (b - m) * x / ((qam + m2) * (a + m2))
        d = 1.0 + aa * d
        d = tiny if abs(d) < tiny else d
        c = 1.0 + aa / c
        c = tiny if abs(c) < tiny else c
        d = 1.0 / d
        h *= d * c
        aa = -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2))
        d = 1.0 + aa * d
        d = tiny if abs(d) < tiny else d
        c = 1.0 + aa / c
        c = tiny if abs(c) < tiny else c
        d = 1.0 / d
        de = d * c
        h *= de
        if abs(de - 1.0) < 3e-14:
            break
    return h


def _betainc(a: float, b: float, x: float) -> float:
    """Regularized incomplete beta I_x(a, b)."""
    if x <= 0.0:
        return 0.0
    if x >= 1.0:
        return 1.0
    lbt = (
        math.lgamma(a + b) - math.lgamma(a) - math.lgamma(b) + a * math.log(x) + b * math.log1p(-x)
    )
    bt = math.exp(lbt)
    if x < (a + 1.0) / (a + b + 2.0):
        return bt * _betacf(a, b, x) / a
    return 1.0 - bt * _betacf(b, a, 1.0 - x) / b


def _gammaq(a: float, x: float) -> float:
    """Regularized upper incomplete gamma Q(a, x) (χ² survival: Q(dof/2, χ²/2))."""
    if x <= 0:
        return 1.0
    gln = math.lgamma(a)
    if x < a + 1.0:
        ap, s = a, 1.0 / a
        d = s
        for _ in range(1000):
            ap += 1.0
            d *= x / ap
            s += d
            if abs(d) < abs(s) * 1e-15:
                break
        return 1.0 - s * math.exp(-x + a * math.log(x) - gln)
    tiny = 1e-300
    b = x + 1.0 - a
    c = 1.0 / tiny
    d = 1.0 / b
    h = d
    for i in range(1, 1000):
        an = -i * (i - a)
        b += 2.0
        d = an * d + b
        d = tiny if abs(d) < tiny else d
        c = b + an / c
        c = tiny if abs(c) < tiny else c
        d = 1.0 / d
        de = d * c
        h *= de
        if abs(de - 1.0) < 1e-15:
            break
    return math.exp(-x + a * math.log(x) - gln) * h


def fit_pearson1(samples: npt.ArrayLike, bins: int = 12) -> PearsonI | None:
    """Fit a Pearson type I (four-parameter beta) law by the method of moments
    and test it with Pearson's χ² (bins merged to expected counts ≥ 5).

    Returns ``None`` when the sample moments fall outside the type I region.
    """
    x = np.asarray(samples, dtype=np.float64)
    x = x[np.isfinite(x)]
    if x.size < 20:
        return None
    mu = float(x.mean())
    sd = float(x.std())
    if sd <= 0:
        return None
    z = (x - mu) / sd
    g1 = float(np.mean(z**3))
    b1 = g1 * g1
    b2 = float(np.mean(z**4))
    den = 6 + 3 * b1 - 2 * b2
    if den == 0:
        return None
    r = 6 * (b2 - b1 - 1) / den
    if r <= 0:
        return None
    root = math.sqrt((r + 2) ** 2 * b1 + 16 * (r + 1))
    # Right-skewed (g1 > 0) → alpha < beta.
    delta = (r + 2) * math.sqrt(b1) / root
    a_ = r / 2 * (1 - delta) if g1 > 0 else r / 2 * (1 + delta)
    b_ = r / 2 * (1 + delta) if g1 > 0 else r / 2 * (1 - delta)
    if a_ <= 0 or b_ <= 0:
        return None
    width = sd / 2 * root
    lower = mu - width * a_ / (a_ + b_)
    upper = lower + width
    fit = PearsonI(a_, b_, lower, upper, float("nan"), 0, float("nan"))
    # χ² goodness of fit on equal-width bins over the sample range, merged.
    edges = np.linspace(float(x.min()), float(x.max()), bins + 1)
    counts, _ = np.histogram(x, edges)
    cdf = np.array([fit.cdf(float(e)) for e in edges])
    cdf[0], cdf[-1] = 0.0, 1.0  # tails go to the outer bins
    expected = np.diff(cdf) * x.size
    obs_m: list[float] = []
    exp_m: list[float] = []
    o_acc = e_acc = 0.0
    for o, e in zip(counts, expected, strict=True):
        o_acc += float(o)
        e_acc += float(e)
        if e_acc >= 5:
            obs_m.append(o_acc)
            exp_m.append(e_acc)
            o_acc = e_acc = 0.0
    if e_acc > 0 and exp_m:
        obs_m[-1] += o_acc
        exp_m[-1] += e_acc
    dof = len(exp_m) - 1 - 4
    if dof < 1:
        return PearsonI(a_, b_, lower, upper, float("nan"), max(dof, 0), float("nan"))
    chi2 = float(sum((o - e) ** 2 / e for o, e in zip(obs_m, exp_m, strict=True)))
    return PearsonI(a_, b_, lower, upper, chi2, dof, _gammaq(dof / 2, chi2 / 2))
