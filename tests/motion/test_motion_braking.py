"""Seed 001: trials (8) and Table 1, exceedance of k measurements over
channels, protective section (6)–(7), Monte Carlo of the braking error (9)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from motion import braking as b

#: The two cells where the printed table differs from the formula rounded up.
DISCREPANCIES = {(1e-2, 0.9): 230, (1e-6, 0.9): 2302584}


@pytest.mark.parametrize(("key", "printed"), list(b.PAPER_TABLE1.items()))
def test_table1_every_cell(key: tuple[float, float], printed: int) -> None:
    p, beta = key
    n = b.trials_needed(p, beta)
    if key in DISCREPANCIES:
        assert n == DISCREPANCIES[key]
        assert n != printed  # the paper's printed value is not the formula's
    else:
        assert n == printed
    # n trials suffice, n - 1 do not
    assert b.p_max_for_trials(n, beta) <= p
    assert b.p_max_for_trials(n - 1, beta) > p


def test_table1_discrepancies_are_exactly_two_and_explained() -> None:
    cells = b.table1()
    bad = [(c.p_max, c.beta, c.computed, c.printed) for c in cells if not c.matches]
    assert bad == [(1e-2, 0.9, 230, 229), (1e-6, 0.9, 2302584, 2302534)]
    # 229 is the formula rounded down: 229 trials only reach β ≈ 0.8999
    raw = math.log(0.1) / math.log(0.99)
    assert math.floor(raw) == 229
    assert 1 - 0.99**229 < 0.9
    # 2302534 is a slipped digit: it would claim β well below 0.9
    assert 1 - (1 - 1e-6) ** 2302534 < 0.9


def test_trials_needed_validates() -> None:
    for p, beta in [(0.0, 0.9), (1.0, 0.9), (0.01, 1.0), (0.01, -0.1)]:
        with pytest.raises(ValueError):
            b.trials_needed(p, beta)


def test_exceedance_k_measurements_and_channels() -> None:
    assert b.exceedance(1e-2, 1) == pytest.approx(1e-2)
    assert b.exceedance(1e-2, 2) == pytest.approx(1e-4)
    assert b.exceedance(1e-2, 3) == pytest.approx(1e-6)
    assert b.exceedance(1e-2, 4) == pytest.approx(1e-8)  # SIL-4
    assert b.exceedance(1e-2, 2, channels=2) == pytest.approx(1e-8)
    assert b.measurements_needed(1e-2, b.SIL4) == 4
    assert b.measurements_needed(1e-2, b.SIL4, channels=2) == 2
    with pytest.raises(ValueError):
        b.exceedance(1e-2, 0)


def test_paper_example_400_m() -> None:
    dl, p = b.range_error_bound(2000.0, 0.20, 459, 0.99)
    assert dl == 400.0
    assert p <= 1e-2
    assert b.exceedance(1e-2, 3) == pytest.approx(1e-6)


def test_braking_plan_protective_section_and_start_point() -> None:
    em = b.ErrorModel(
        delta_s_max_m=3.0,
        p_s=1e-2,
        delta_l_max_m=40.0,
        p_l=1e-2,
        measurements=3,
        measurement_time_s=0.5,
    )
    v = 20.0
    plan = b.braking_plan(
        v, 0.8, reaction_time_s=2.0, gradient_permille=0.0, errors=em, obstacle_at_m=5000.0
    )
    s = v * 2.0 + v**2 / (2 * 0.8)
    assert plan.braking_distance_m == pytest.approx(s)
    assert plan.delta_l_max_m == pytest.approx(40.0 + v * 3 * 0.5)  # grows during k measurements
    assert plan.protective_section_m == pytest.approx(3.0 + 70.0)
    assert plan.brake_at_measured_distance_m == pytest.approx(s + 73.0)  # eq. (6)
    assert plan.brake_start_coordinate_m == pytest.approx(5000.0 - s - 73.0)
    assert plan.collision_probability_bound == pytest.approx(1e-2 * 1e-6)  # eq. (7)
    assert plan.meets_sil4
    # one measurement only: 1e-4, not SIL-4
    one = b.braking_plan(v, 0.8, errors=b.ErrorModel(3.0, 1e-2, 40.0, 1e-2))
    assert not one.meets_sil4


def test_gradient_and_max_safe_speed() -> None:
    flat = b.braking_distance(20.0, 0.8)
    down = b.braking_distance(20.0, 0.8, gradient_permille=-10.0)
    up = b.braking_distance(20.0, 0.8, gradient_permille=10.0)
    assert up < flat < down
    with pytest.raises(ValueError):
        b.braking_distance(20.0, 0.05, gradient_permille=-10.0)
    em = b.ErrorModel(3.0, 1e-2, 40.0, 1e-2, 2, 1, 0.5)
    vmax = b.max_safe_speed(600.0, 0.8, reaction_time_s=2.0, gradient_permille=-5.0, errors=em)
    plan = b.braking_plan(vmax, 0.8, reaction_time_s=2.0, gradient_permille=-5.0, errors=em)
    assert plan.brake_at_measured_distance_m == pytest.approx(600.0)
    assert b.max_safe_speed(20.0, 0.8, errors=em) == 0.0


@pytest.mark.parametrize("control", ["deceleration", "speed"])
def test_monte_carlo_braking_error(control: str) -> None:
    r = b.braking_error_monte_carlo(230, control=control, seed=1)  # type: ignore[arg-type]
    e = np.asarray(r.errors_m)
    assert r.runs == e.size == 230
    assert sum(r.counts) == 230
    # errors of metres around a ~200 m braking distance, centred
    assert 150 < r.nominal_distance_m < 250
    assert abs(r.mean_m) < 0.5
    assert 0.3 < r.std_m < 3.0
    assert e.min() < 0 < e.max()
    assert r.delta_s_max_m == pytest.approx(-e.min())
    # 230 runs without a larger error: exceedance ≤ 1e-2 at β = 0.9
    assert r.p_exceed <= 1e-2
    assert r.trials_for == {"1e-02": 230, "1e-04": 23025, "1e-06": 2302584}
    again = b.braking_error_monte_carlo(230, control=control, seed=1)  # type: ignore[arg-type]
    assert again.errors_m == r.errors_m


def test_pearson_type_i_fit_recovers_a_beta_law() -> None:
    rng = np.random.default_rng(3)
    x = -3.0 + 4.5 * rng.beta(2.5, 4.0, 20000)  # the paper's −3 … 1.5 m range
    fit = b.fit_pearson1(x)
    assert fit is not None
    assert fit.alpha == pytest.approx(2.5, rel=0.1)
    assert fit.beta == pytest.approx(4.0, rel=0.1)
    assert fit.lower == pytest.approx(-3.0, abs=0.1)
    assert fit.upper == pytest.approx(1.5, abs=0.1)
    assert fit.p_value > 0.01
    # too small a sample is not fitted
    assert b.fit_pearson1(rng.uniform(0, 1, 10)) is None
