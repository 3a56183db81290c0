"""The vectorized fleet assessment equals assess_car car by car."""

from __future__ import annotations

import numpy as np
import pytest

from maintenance import assess_car, assess_fleet, rank_fleet
from maintenance.simulate import simulate_fleet


@pytest.fixture(scope="module")
def fleet():  # type: ignore[no-untyped-def]
    return simulate_fleet(80, seed=4)


@pytest.mark.parametrize(("trend", "window"), [("linear", 40), ("none", None), ("quadratic", 60)])
def test_assess_fleet_matches_assess_car(fleet, trend: str, window: int | None) -> None:  # type: ignore[no-untyped-def]
    w = np.random.default_rng(0).dirichlet(np.ones(20))
    kwargs = {"band": fleet.bands, "weights": w, "index_band": (0.9, 1.2), "trend": trend,
              "window": window, "names": fleet.names, "k": 2}  # fmt: skip
    ids = [f"{i:04d}" for i in range(80)]
    batch = assess_fleet(fleet.histories, times=fleet.times, car_ids=ids, **kwargs)  # type: ignore[arg-type]
    for h, car, got in zip(fleet.histories, ids, batch, strict=True):
        want = assess_car(h, times=fleet.times, car_id=car, **kwargs)  # type: ignore[arg-type]
        assert got.car_id == car and got.first_exit == want.first_exit
        assert got.reasons == want.reasons
        assert got.forecast is not None and want.forecast is not None
        np.testing.assert_allclose(got.forecast.values, want.forecast.values, atol=1e-10)
        np.testing.assert_allclose(got.forecast.std, want.forecast.std, atol=1e-10)
        np.testing.assert_allclose(
            got.forecast.coefficients, want.forecast.coefficients, atol=1e-10
        )
        np.testing.assert_allclose(got.contributions, want.contributions, atol=1e-12)
        assert got.risk == pytest.approx(want.risk, abs=1e-10)
        assert got.k_of_l_probability == pytest.approx(want.k_of_l_probability, abs=1e-10)
    assert len(rank_fleet(batch)) == 80


def test_assess_fleet_short_histories_report_not_enough_history(fleet) -> None:  # type: ignore[no-untyped-def]
    out = assess_fleet(fleet.histories[:3, :4], times=fleet.times[:4], band=fleet.bands,
                       weights=np.full(20, 0.05))  # fmt: skip
    assert [a.status for a in out] == ["not_enough_history"] * 3


def test_assess_fleet_rejects_bad_input(fleet) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(ValueError, match="3-D"):
        assess_fleet(fleet.histories[0], times=fleet.times, band=fleet.bands, weights=np.ones(20))
    with pytest.raises(ValueError, match="weights has 3"):
        assess_fleet(fleet.histories, times=fleet.times, band=fleet.bands, weights=np.ones(3))
    with pytest.raises(ValueError, match="car_ids"):
        assess_fleet(fleet.histories, times=fleet.times, band=fleet.bands, weights=np.ones(20),
                     car_ids=["a"])  # fmt: skip
