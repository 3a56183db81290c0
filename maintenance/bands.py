"""Per-parameter tolerance bands and the normalised indicators of the index.

A parameter's band is ``nominal ± tolerance`` (or any ``(lower, upper)``). Each
measurement becomes the dimensionless indicator ``x̃ = 1 + (x − centre)/half_width``:
the band centre maps to 1 and the band limits to 0 and 2, so the index of a
perfectly serviceable car is 1 (``Wᵀ·x0 = 1`` with ``x0 = (1, …, 1)``) and every
parameter is out of tolerance exactly when its indicator leaves ``[0, 2]``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from maintenance._checks import FloatArray, as_matrix, as_vector, check_band

INDICATOR_BAND: tuple[float, float] = (0.0, 2.0)


def bands_from_nominal(nominal: Any, tolerance: Any) -> FloatArray:
    """Bands ``nominal ± tolerance``.

    Parameters
    ----------
    nominal : array_like, shape (n_params,)
        Nominal values (the band centres), in each parameter's unit.
    tolerance : array_like, shape (n_params,) or scalar
        Allowed deviation (positive), same units.

    Returns
    -------
    ndarray, shape (n_params, 2)
        ``(lower, upper)`` per parameter.
    """
    centre = as_vector(nominal, "nominal")
    tol = np.broadcast_to(np.asarray(tolerance, dtype=np.float64), centre.shape)
    if not np.all(np.isfinite(tol)) or np.any(tol <= 0.0):
        raise ValueError("tolerance must be positive and finite")
    return np.column_stack([centre - tol, centre + tol])


def parameter_bands(band: Any, n_params: int) -> FloatArray:
    """Normalise ``band`` to shape (n_params, 2).

    ``band`` is one ``(lower, upper)`` pair shared by all parameters, or an
    array of shape (n_params, 2) with one pair per parameter.
    """
    arr = np.asarray(band, dtype=np.float64)
    if arr.shape == (2,):
        lo, hi = check_band(arr)
        return np.tile([lo, hi], (n_params, 1))
    table = as_matrix(arr, "band")
    if table.shape != (n_params, 2):
        raise ValueError(f"band must be (lower, upper) or shape ({n_params}, 2), got {arr.shape}")
    bad = np.flatnonzero(table[:, 0] >= table[:, 1])
    if bad.size:
        raise ValueError(f"band of parameter {int(bad[0])} must satisfy lower < upper")
    return table


def to_indicators(X: Any, bands: Any) -> FloatArray:
    """Indicators ``1 + (x − centre)/half_width`` of measurements ``X``.

    Parameters
    ----------
    X : array_like, shape (..., n_params)
        Measurements in each parameter's unit.
    bands : array_like, shape (n_params, 2)
        ``(lower, upper)`` per parameter.

    Returns
    -------
    ndarray, same shape as ``X``; 1 at the centre, 0/2 at the limits.
    """
    data = np.asarray(X, dtype=np.float64)
    table = parameter_bands(bands, data.shape[-1])
    centre = table.mean(axis=1)
    half = 0.5 * (table[:, 1] - table[:, 0])
    return np.asarray(1.0 + (data - centre) / half, dtype=np.float64)
