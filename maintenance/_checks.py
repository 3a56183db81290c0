"""Input checks shared by the maintenance modules (clear ``ValueError`` messages)."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


def as_vector(values: Any, name: str, *, min_length: int = 1) -> FloatArray:
    """Return ``values`` as a finite 1-D float64 copy, or raise ``ValueError``."""
    try:
        arr = np.array(values, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be numeric, got {type(values).__name__}") from exc
    if arr.ndim != 1:
        raise ValueError(f"{name} must be 1-D, got shape {arr.shape}")
    if arr.shape[0] < min_length:
        raise ValueError(f"{name} needs at least {min_length} values, got {arr.shape[0]}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} contains NaN or infinite values")
    return arr


def as_matrix(values: Any, name: str, *, min_rows: int = 1) -> FloatArray:
    """Return ``values`` as a finite 2-D float64 copy (rows = samples), or raise."""
    try:
        arr = np.array(values, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be numeric, got {type(values).__name__}") from exc
    if arr.ndim != 2:
        raise ValueError(f"{name} must be 2-D (n_samples, n_params), got shape {arr.shape}")
    if arr.shape[0] < min_rows:
        raise ValueError(f"{name} needs at least {min_rows} rows, got {arr.shape[0]}")
    if arr.shape[1] < 1:
        raise ValueError(f"{name} needs at least one parameter column")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} contains NaN or infinite values")
    return arr


def check_positive_int(value: Any, name: str, *, minimum: int = 1) -> int:
    """Return ``value`` as an int >= ``minimum`` or raise ``ValueError``."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise ValueError(f"{name} must be an integer, got {value!r}")
    if int(value) < minimum:
        raise ValueError(f"{name} must be >= {minimum}, got {value}")
    return int(value)


def check_probability(value: Any, name: str, *, open_interval: bool = False) -> float:
    """Return ``value`` as a float probability or raise ``ValueError``."""
    p = float(value)
    if not np.isfinite(p) or p < 0.0 or p > 1.0 or (open_interval and p in (0.0, 1.0)):
        bounds = "(0, 1)" if open_interval else "[0, 1]"
        raise ValueError(f"{name} must be in {bounds}, got {value!r}")
    return p


def check_band(band: Any, name: str = "band") -> tuple[float, float]:
    """Return ``(lower, upper)`` with lower < upper, or raise ``ValueError``."""
    try:
        lower, upper = (float(v) for v in band)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be a pair (lower, upper), got {band!r}") from exc
    if not (np.isfinite(lower) and np.isfinite(upper)) or lower >= upper:
        raise ValueError(f"{name} must satisfy lower < upper (finite), got {band!r}")
    return lower, upper
