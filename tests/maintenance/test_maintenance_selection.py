"""Parameter selection by derivative norm and entropy."""

from __future__ import annotations

import numpy as np
import pytest

from maintenance import (
    derivative_norm,
    gaussian_entropy,
    select_by_derivative_norm,
    select_by_entropy,
)


def test_derivative_norm_of_a_line() -> None:
    t = np.linspace(0.0, 10.0, 101)
    X = np.column_stack([2.0 + 0.5 * t, np.full_like(t, -1.0)])
    norm = derivative_norm(X, times=t, n_derivatives=2)
    assert norm[0] == pytest.approx(np.mean(2.0 + 0.5 * t) + 0.5, abs=1e-9)  # |x| + |x'| + 0
    assert norm[1] == pytest.approx(1.0)


def test_select_by_derivative_norm_keeps_moving_parameters() -> None:
    rng = np.random.default_rng(0)
    t = np.arange(200.0)
    X = np.column_stack([0.01 * rng.normal(size=200), 0.02 * t, 0.01 * rng.normal(size=200)])
    keep = select_by_derivative_norm(X, times=t, threshold=0.5, n_derivatives=1)
    assert keep.tolist() == [1]
    scaled = derivative_norm(X, times=t, n_derivatives=0, scale=[0.01, 1.0, 0.01])
    assert scaled[0] == pytest.approx(np.mean(np.abs(X[:, 0])) / 0.01)


def test_gaussian_entropy_value_and_selection() -> None:
    rng = np.random.default_rng(1)
    sigma = np.array([2.0, 0.1, 0.5, 1.0])
    X = rng.normal(size=(50000, 4)) * sigma
    h = gaussian_entropy(X)
    np.testing.assert_allclose(h, 0.5 * np.log2(2 * np.pi * np.e * sigma**2), atol=0.01)
    assert select_by_entropy(X, n_keep=2).tolist() == [1, 2]
    assert select_by_entropy(X, threshold=1.5).tolist() == [1, 2]


def test_constant_parameter_is_never_selected() -> None:
    X = np.column_stack([np.ones(10), np.arange(10.0)])
    assert gaussian_entropy(X)[0] == -np.inf
    assert select_by_entropy(X, n_keep=2).tolist() == [1]


def test_selection_errors() -> None:
    X = np.random.default_rng(2).normal(size=(20, 3))
    with pytest.raises(ValueError, match="strictly increasing"):
        derivative_norm(X, times=np.zeros(20))
    with pytest.raises(ValueError, match="exactly one"):
        select_by_entropy(X)
    with pytest.raises(ValueError, match="positive"):
        gaussian_entropy(X, scale=[1.0, 0.0, 1.0])


def test_select_by_weights() -> None:
    from maintenance.selection import select_by_weights

    assert select_by_weights([0.1, -0.5, 0.3, 0.01], threshold=0.1).tolist() == [1, 2, 0]
