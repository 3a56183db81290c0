"""K-of-L probability (exact and inclusion–exclusion) and the index band."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from maintenance import (
    at_least_k_inclusion_exclusion,
    at_least_k_probability,
    independent_intersection_sums,
    intersection_sums,
    tolerance_band,
)

P = np.array([0.1, 0.5, 0.3, 0.9, 0.05, 0.6])


def _brute_force(p: np.ndarray, k: int) -> float:
    total = 0.0
    for outcome in itertools.product([0, 1], repeat=len(p)):
        if sum(outcome) >= k:
            total += float(np.prod([q if o else 1 - q for q, o in zip(p, outcome, strict=True)]))
    return total


@pytest.mark.parametrize("k", range(1, 7))
def test_at_least_k_matches_enumeration_and_inclusion_exclusion(k: int) -> None:
    exact = _brute_force(P, k)
    assert at_least_k_probability(P, k) == pytest.approx(exact, abs=1e-12)
    s = independent_intersection_sums(P)
    assert at_least_k_inclusion_exclusion(s, k) == pytest.approx(exact, abs=1e-12)


def test_known_values() -> None:
    assert at_least_k_probability([0.5, 0.5], 1) == pytest.approx(0.75)
    assert at_least_k_probability([0.5, 0.5], 2) == pytest.approx(0.25)
    assert at_least_k_probability([0.2] * 3, 3) == pytest.approx(0.008)


@pytest.mark.parametrize("k", range(1, 5))
def test_inclusion_exclusion_with_dependent_events_is_exact(k: int) -> None:
    """For the empirical joint law, (4.18) equals the observed frequency exactly."""
    rng = np.random.default_rng(0)
    common = rng.normal(size=(5000, 1))
    outside = (common + rng.normal(size=(5000, 4)) * [0.5, 1.0, 0.8, 1.2]) > 1.0
    freq = float(np.mean(outside.sum(axis=1) >= k))
    assert at_least_k_inclusion_exclusion(intersection_sums(outside), k) == pytest.approx(
        freq, abs=1e-12
    )
    if k == 2:  # positive dependence: independence would understate it
        assert freq > at_least_k_probability(outside.mean(axis=0), k)


def test_k_of_l_rejects_bad_input() -> None:
    with pytest.raises(ValueError, match="exceeds"):
        at_least_k_probability([0.1, 0.2], 3)
    with pytest.raises(ValueError, match="probabilities"):
        at_least_k_probability([0.1, 1.2], 1)
    with pytest.raises(ValueError, match=">= 1"):
        at_least_k_inclusion_exclusion([0.1, 0.01], 0)
    with pytest.raises(ValueError, match="2-D"):
        intersection_sums([True, False])


def test_tolerance_band_equal_tails_without_faulty() -> None:
    good = np.random.default_rng(1).normal(1.0, 0.05, 20000)
    band = tolerance_band(good, false_alarm=0.05)
    assert band.false_alarm == pytest.approx(0.05, abs=0.002)
    assert band.lower == pytest.approx(1.0 - 1.96 * 0.05, abs=0.005)
    assert band.upper == pytest.approx(1.0 + 1.96 * 0.05, abs=0.005)
    assert band.detection is None


def test_tolerance_band_spends_alpha_where_faults_are() -> None:
    rng = np.random.default_rng(2)
    good = rng.normal(1.0, 0.05, 20000)
    bad = rng.normal(1.12, 0.05, 2000)  # faults push the index up
    band = tolerance_band(good, false_alarm=0.05, faulty=bad)
    equal = tolerance_band(good, false_alarm=0.05)
    assert band.false_alarm <= 0.05 + 1e-3
    assert band.detection is not None
    assert band.detection > float(np.mean((bad < equal.lower) | (bad > equal.upper)))
    assert band.upper == pytest.approx(1.0 + 1.645 * 0.05, abs=0.006)  # one-sided


def test_tolerance_band_rejects_bad_alpha() -> None:
    with pytest.raises(ValueError, match="false_alarm"):
        tolerance_band([1.0, 2.0, 3.0], false_alarm=0.0)


from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(0.0, 1.0), min_size=1, max_size=9), st.data())
def test_exact_and_inclusion_exclusion_agree(p: list[float], data: st.DataObject) -> None:
    k = data.draw(st.integers(1, len(p)))
    exact = at_least_k_probability(p, k)
    assert at_least_k_inclusion_exclusion(independent_intersection_sums(p), k) == pytest.approx(
        exact, abs=1e-9
    )
    assert 0.0 <= exact <= 1.0
