"""Economic effect (4.4): discounted cumulative saving."""

from __future__ import annotations

import numpy as np
import pytest

from maintenance.economics import discount_factors, economic_effect


def test_economic_effect_by_hand() -> None:
    alpha = discount_factors([2008, 2009, 2010], reference_year=2008, rate=0.1)
    np.testing.assert_allclose(alpha, [1.0, 1 / 1.1, 1 / 1.21])
    # (1000-600-100)*1 + (1000-500-50)/1.1 + (1200-500-50)/1.21
    expected = 300 + 450 / 1.1 + 650 / 1.21
    got = economic_effect([1000, 1000, 1200], [600, 500, 500], [100, 50, 50], alpha)
    assert got == pytest.approx(expected)


def test_economic_effect_rejects_mismatched_years() -> None:
    with pytest.raises(ValueError, match="one value per year"):
        economic_effect([1.0, 2.0], [1.0], [0.0, 0.0], [1.0, 1.0])
    with pytest.raises(ValueError, match="rate"):
        discount_factors([2008], reference_year=2008, rate=-1.0)
