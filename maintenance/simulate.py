"""Fleet simulator: metro cars with noisy, correlated parameters and slow wear.

Serviceable cars keep every parameter near its band centre with stationary,
correlated noise (two shared AR(1) factors — ambient temperature and load —
plus each parameter's own AR(1) noise). Degrading cars additionally wear: the
*stable* pneumatic-timing parameters (small noise relative to their
tolerance, the thesis's telling parameters) drift towards their upper limits,
following ``D(t) = d·((t − onset)/(exit − onset))^γ`` (γ ≥ 1: wear accelerates).
Truth is noise-free: a car leaves tolerance when at least K of its
parameters' noise-free values are outside their bands (the spec's K-of-L
failure criterion).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from maintenance._checks import FloatArray, check_positive_int, check_probability
from maintenance.bands import bands_from_nominal
from maintenance.calibration import FleetCalibration, calibrate_fleet

# name, nominal, tolerance (±), unit noise class: "stable" or "noisy"
PARAMETERS: tuple[tuple[str, float, float, str], ...] = (
    ("brake_cylinder_fill_s", 3.0, 0.6, "stable"),
    ("brake_release_s", 4.0, 0.8, "stable"),
    ("door_close_s", 2.4, 0.5, "stable"),
    ("door_open_s", 2.0, 0.4, "stable"),
    ("compressor_fill_s", 45.0, 9.0, "stable"),
    ("brake_pipe_leak_bar_min", 0.3, 0.2, "stable"),
    ("motor_insulation_mohm", 48.0, 20.0, "noisy"),
    ("traction_current_a", 310.0, 60.0, "noisy"),
    ("motor_winding_temp_c", 85.0, 25.0, "noisy"),
    ("gearbox_oil_temp_c", 60.0, 20.0, "noisy"),
    ("axle_box_temp_c", 40.0, 20.0, "noisy"),
    ("battery_voltage_v", 80.0, 8.0, "noisy"),
    ("auxiliary_converter_v", 380.0, 40.0, "noisy"),
    ("collector_shoe_force_n", 150.0, 30.0, "noisy"),
    ("wheel_flange_mm", 30.0, 3.0, "noisy"),
    ("wheel_diameter_spread_mm", 0.5, 0.5, "noisy"),
    ("suspension_height_mm", 1100.0, 15.0, "noisy"),
    ("cabin_temperature_c", 21.0, 5.0, "noisy"),
    ("vibration_rms_g", 0.15, 0.08, "noisy"),
    ("noise_level_db", 72.0, 6.0, "noisy"),
)
WEAR_MODE: tuple[int, ...] = (0, 1, 2, 3, 4, 5)  # the stable pneumatic group wears together


@dataclass(frozen=True)
class SimulatedFleet:
    """A generated fleet.

    Attributes
    ----------
    histories : ndarray, shape (n_cars, n_times, n_params)
        Measured history, parameter units.
    futures : ndarray, shape (n_cars, horizon, n_params)
        What the next ``horizon`` measurements would be (for checking).
    times : ndarray, shape (n_times,)
        Measurement times, days (one measurement per day).
    bands : ndarray, shape (n_params, 2)
        Tolerance bands ``nominal ± tolerance``.
    names : tuple of str
    degrading : ndarray of bool, shape (n_cars,)
    exit_step : ndarray, shape (n_cars,)
        Steps after the last measurement at which the noise-free state first
        leaves tolerance (<= 0: already out; ``inf``: never).
    leaves_within_horizon : ndarray of bool, shape (n_cars,)
        Noise-free state out of tolerance at some step ``1 … horizon``.
    faulty_states : ndarray of bool, shape (n_cars, n_times + horizon)
        Noise-free out-of-tolerance flag of every step (history then future).
    horizon : int
    """

    histories: FloatArray
    futures: FloatArray
    times: FloatArray
    bands: FloatArray
    names: tuple[str, ...]
    degrading: NDArray[np.bool_]
    exit_step: FloatArray
    leaves_within_horizon: NDArray[np.bool_]
    faulty_states: NDArray[np.bool_]
    horizon: int


def _ar1(rng: np.random.Generator, shape: tuple[int, ...], rho: float) -> FloatArray:
    """Unit-variance AR(1) along axis 1."""
    e = rng.standard_normal(shape)
    out = np.empty(shape)
    out[:, 0] = e[:, 0]
    scale = np.sqrt(1.0 - rho * rho)
    for t in range(1, shape[1]):
        out[:, t] = rho * out[:, t - 1] + scale * e[:, t]
    return out


def _noise(rng: np.random.Generator, n_cars: int, n_steps: int) -> tuple[FloatArray, FloatArray]:
    """Per-car offsets (n_cars, 1, n_params) and correlated noise (n_cars, n_steps, n_params).

    Both in tolerance half-widths (indicator units minus 1).
    """
    stable = np.array([kind == "stable" for *_, kind in PARAMETERS])
    sigma = np.where(
        stable, rng.uniform(0.03, 0.07, stable.size), rng.uniform(0.15, 0.35, stable.size)
    )
    loadings = rng.normal(0.0, 0.6, (2, stable.size)) * sigma  # shared factors ~ 1/3 of variance
    factors = _ar1(rng, (n_cars, n_steps, 2), 0.8)
    own = _ar1(rng, (n_cars, n_steps, stable.size), 0.3) * sigma * 0.8
    offsets = rng.normal(0.0, 1.0, (n_cars, 1, stable.size)) * np.where(stable, 0.03, 0.12)
    return offsets, np.asarray(factors @ loadings + own, dtype=np.float64)


def _wear(
    rng: np.random.Generator,
    n_steps: int,
    last: int,
    horizon: int,
    offset: FloatArray,
    k: int,
) -> tuple[FloatArray, float]:
    """Wear displacement (n_steps, n_params) of one degrading car and its exit step."""
    loading = np.zeros(len(PARAMETERS))
    loading[list(WEAR_MODE)] = rng.uniform(0.95, 1.05, len(WEAR_MODE))
    exit_at = float(rng.uniform(last - 10, last + horizon + 70))
    onset = float(rng.uniform(20.0, min(exit_at - 60.0, last - 40.0)))
    gamma = float(rng.uniform(1.0, 1.3))
    mode = np.array(WEAR_MODE)
    # the k-th parameter of the mode reaches its limit exactly at exit_at
    depth = float(np.sort((1.0 - offset[mode]) / loading[mode])[k - 1])
    t = np.arange(n_steps, dtype=np.float64)
    wear = depth * (np.clip(t - onset, 0.0, None) / (exit_at - onset)) ** gamma
    return wear[:, None] * loading, exit_at - last


def simulate_fleet(
    n_cars: int = 200,
    *,
    n_times: int = 200,
    horizon: int = 30,
    degrading_fraction: float = 0.35,
    failure_k: int = 2,
    seed: int = 0,
) -> SimulatedFleet:
    """Generate a fleet's measurement histories and the truth about their wear.

    Parameters
    ----------
    n_cars : int
    n_times : int
        Measurements per car (daily), >= 60.
    horizon : int
        Forecast horizon for the truth (steps after the last measurement).
    degrading_fraction : float
        Share of cars that wear; their exits fall uniformly between 10 steps
        before the last measurement and ``horizon + 70`` steps after it.
    failure_k : int
        Failure criterion of the spec: the car is out of tolerance when at
        least ``failure_k`` parameters are (noise-free) outside their bands.
    seed : int
        Random seed (results are reproducible).
    """
    cars = check_positive_int(n_cars, "n_cars")
    n = check_positive_int(n_times, "n_times", minimum=60)
    h = check_positive_int(horizon, "horizon")
    share = check_probability(degrading_fraction, "degrading_fraction")
    k = check_positive_int(failure_k, "failure_k")
    if k > len(WEAR_MODE):
        raise ValueError(f"failure_k={k} exceeds the {len(WEAR_MODE)} parameters that wear")
    rng = np.random.default_rng(seed)
    total = n + h
    offsets, noise = _noise(rng, cars, total)
    clean = np.repeat(offsets, total, axis=1)
    z = clean + noise
    degrading = rng.random(cars) < share
    exit_step = np.full(cars, np.inf)
    for c in np.flatnonzero(degrading):
        wear, exit_step[c] = _wear(rng, total, n - 1, h, clean[c, 0], k)
        z[c] += wear
        clean[c] += wear
    faulty = np.sum(np.abs(clean) > 1.0, axis=2) >= k
    nominal = np.array([p[1] for p in PARAMETERS])
    tol = np.array([p[2] for p in PARAMETERS])
    values = nominal + z * tol
    return SimulatedFleet(
        histories=values[:, :n],
        futures=values[:, n:],
        times=np.arange(n, dtype=np.float64),
        bands=bands_from_nominal(nominal, tol),
        names=tuple(p[0] for p in PARAMETERS),
        degrading=degrading,
        exit_step=exit_step,
        leaves_within_horizon=np.any(faulty[:, n:], axis=1),
        faulty_states=faulty,
        horizon=h,
    )


def demo_calibration(
    method: str = "prediction", *, seed: int = 1, n_cars: int = 800
) -> FleetCalibration:
    """Weights and index band calibrated on a simulated reference fleet (for demos).

    Use with fleets from :func:`simulate_fleet` (same parameters and bands) and
    ``assess_car(..., window=40)``: ``assess_car(h, times=t, band=f.bands,
    weights=cal.weights, index_band=cal.index_band)``.
    """
    reference = simulate_fleet(n_cars, n_times=230, seed=seed)
    return calibrate_fleet(
        reference.histories,
        band=reference.bands,
        faulty=reference.faulty_states[:, :230],
        method=method,
    )
