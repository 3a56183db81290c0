"""Generated train runs (fixed seeds) for testing and benchmarking the fusion.

A run is a line with curves and gradients, track markers every 1–2 km with
geographic positions, and a train that starts from a station, accelerates,
cruises (with a speed restriction on the way), brakes and stops at a dead
end.  On board:

* accelerometer at 10 Hz on the car's axis: specific force (gravity on the
  gradient included) + a bias of ±0.02 m/s² + white noise 0.05 m/s²;
* GNSS speed at 1 Hz, 2 s late, noise 0.03 m/s; GNSS fixes at 1 Hz, 2 s
  late, error a Gauss–Markov process of 8 m per axis (60 s correlation);
  both lost for 60 s in each tunnel (two or three tunnels per run, one
  of them, in half of the runs, over the final stop);
* a marker reader that reads a marker when the train passes it *and the
  filter has the reader switched on*; one marker per run is never read
  (:mod:`motion.simulation.runner` closes that loop).

The shape of the line and of the drive is :class:`Scenario`; the sensor
figures are the keyword arguments of :func:`generate_run`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from ..model import PER_MILLE, G
from ..track import EARTH_R, Marker, MarkerTable

__all__ = ["LAT0", "LON0", "Run", "Scenario", "generate_run"]

FloatArray = npt.NDArray[np.float64]
LAT0, LON0 = 50.4501, 30.5234  # where the generated lines start (degrees)


@dataclass(frozen=True)
class Scenario:
    """The random line and drive of a run: ranges are drawn uniformly (SI units).

    Changing a value changes every generated run (the tests' figures are
    measured on the defaults).
    """

    # -- the line
    markers: tuple[int, int] = (5, 9)  # number of markers, [low, high)
    marker_spacing_m: tuple[float, float] = (1000.0, 2000.0)
    stop_after_last_m: tuple[float, float] = (300.0, 1500.0)  # the dead end
    overrun_m: float = 200.0  # track beyond the dead end
    geometry_step_m: float = 10.0  # the dense polyline; every 20th point goes in the table
    curve_segment_m: tuple[float, float] = (500.0, 2000.0)
    straight_share: float = 0.4  # of the segments
    curve_radius_m: tuple[float, float] = (800.0, 4000.0)
    gradient_permille: tuple[float, float] = (-8.0, 8.0)
    gradient_segment_m: tuple[float, float] = (500.0, 2000.0)
    # -- the speed profile
    cruise_mps: tuple[float, float] = (15.0, 25.0)
    restriction_at: tuple[float, float] = (0.3, 0.6)  # share of the way to the stop
    restriction_m: tuple[float, float] = (300.0, 800.0)
    restriction_mps: tuple[float, float] = (8.0, 12.0)
    traction_mps2: tuple[float, float] = (0.6, 1.0)
    braking_mps2: tuple[float, float] = (0.5, 0.8)
    # -- the drive
    start_before_first_m: tuple[float, float] = (100.0, 400.0)  # the station track
    dwell_s: float = 10.0  # standing at the start
    speed_gain_per_s: float = 0.8  # the driver's response to the speed error
    braking_reserve: float = 1.05  # the driver may brake 5 % harder than planned
    creep_m: float = 0.3  # last metres to the dead end, crept at creep_mps2
    creep_mps: float = 0.3
    creep_mps2: float = 0.3
    response_s: float = 0.8  # traction/brake time constant (jerk limit)
    stand_s: float = 15.0  # standing at the end
    stopped_after_s: float = 15.0  # a standstill after this time is the final stop
    max_duration_s: float = 4000.0
    # -- GNSS outages and errors, the on-board start estimate
    tunnels: tuple[int, int] = (2, 4)  # [low, high)
    first_tunnel_s: float = 30.0  # tunnels start after this, and at least
    tunnel_room_s: float = 200.0  # this long before the end (in runs long enough)
    tunnel_over_stop_share: float = 0.5  # of the runs
    tunnel_over_stop_end_s: float = 20.0  # it ends at most this long before the run
    fix_correlation_s: float = 60.0
    start_estimate_sigma_m: float = 3.0


DEFAULT_SCENARIO = Scenario()


@dataclass
class Run:
    """One generated run: truth and the on-board event stream."""

    seed: int
    table: MarkerTable
    t: FloatArray  # accelerometer sample times (10 Hz)
    s_true: FloatArray  # true track coordinate at t
    v_true: FloatArray
    accel_meas: FloatArray
    gnss_ok: npt.NDArray[np.bool_]  # GNSS available at t (outside tunnels)
    gnss_speed: dict[int, float]  # sample index → delayed GNSS speed reported there
    gnss_fix: dict[int, tuple[float, float]]  # sample index → delayed (lat, lon)
    marker_pass: list[tuple[float, str, float]]  # (time, marker id, coordinate), all passes
    missed_id: str
    delay_s: float
    stop_m: float
    tunnels: list[tuple[float, float]]  # time intervals without GNSS
    bias: float
    start_estimate_m: float  # the start as the on-board unit knows it (±3 m)
    accel_noise: float

    @property
    def final_position(self) -> float:
        return float(self.s_true[-1])


def _uniform(rng: np.random.Generator, r: tuple[float, float]) -> float:
    return float(rng.uniform(r[0], r[1]))


def _geometry(
    length: float, rng: np.random.Generator, sc: Scenario
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """A curved line: a point every ``geometry_step_m`` → (s, lat, lon)."""
    ds = sc.geometry_step_m
    n = int(length / ds) + 2
    s = np.arange(n, dtype=np.float64) * ds
    curv = np.zeros(n)
    pos = 0.0
    while pos < length:
        seg = _uniform(rng, sc.curve_segment_m)
        straight = rng.random() < sc.straight_share
        k = 0.0 if straight else rng.choice([-1, 1]) / _uniform(rng, sc.curve_radius_m)
        curv[(s >= pos) & (s < pos + seg)] = k
        pos += seg
    heading = np.cumsum(curv) * ds + rng.uniform(0, 2 * math.pi)
    x = np.concatenate([[0.0], np.cumsum(np.cos(heading[:-1]) * ds)])
    y = np.concatenate([[0.0], np.cumsum(np.sin(heading[:-1]) * ds)])
    lat = LAT0 + np.degrees(y / EARTH_R)
    lon = LON0 + np.degrees(x / (EARTH_R * math.cos(math.radians(LAT0))))
    return s, lat, lon


def _gradients(rng: np.random.Generator, length: float, sc: Scenario) -> list[tuple[float, float]]:
    pts: list[tuple[float, float]] = []
    pos = 0.0
    while pos < length:
        pts.append((pos, _uniform(rng, sc.gradient_permille)))
        pos += _uniform(rng, sc.gradient_segment_m)
    return pts


def _line(
    rng: np.random.Generator, gradients: bool, sc: Scenario
) -> tuple[MarkerTable, float, tuple[FloatArray, FloatArray, FloatArray]]:
    """Markers, the dead end after the last one, a curved line with
    gradients.  Returns (table, stop coordinate, dense geometry)."""
    coords = [0.0]
    for _ in range(int(rng.integers(*sc.markers)) - 1):
        coords.append(coords[-1] + _uniform(rng, sc.marker_spacing_m))
    stop = coords[-1] + _uniform(rng, sc.stop_after_last_m)
    length = stop + sc.overrun_m
    gs, glat, glon = _geometry(length, rng, sc)
    markers = [
        Marker(f"M{k:02d}", c, float(np.interp(c, gs, glat)), float(np.interp(c, gs, glon)))
        for k, c in enumerate(coords)
    ]
    grad_pts = _gradients(rng, length, sc) if gradients else []
    geometry = [
        (float(a), float(b), float(c))
        for a, b, c in zip(gs[::20], glat[::20], glon[::20], strict=True)
    ]
    return MarkerTable(markers, gradients=grad_pts, geometry=geometry), stop, (gs, glat, glon)


def _speed_limit(
    rng: np.random.Generator, stop: float, sc: Scenario
) -> tuple[Callable[[float], float], float, float]:
    """A line speed, a restriction on the way and the braking curve to the
    dead end.  Returns (limit(x), traction acceleration, braking rate)."""
    v_cruise = _uniform(rng, sc.cruise_mps)
    restr_at = _uniform(rng, sc.restriction_at) * stop
    restr_len = _uniform(rng, sc.restriction_m)
    v_restr = _uniform(rng, sc.restriction_mps)
    a_acc = _uniform(rng, sc.traction_mps2)
    a_brk = _uniform(rng, sc.braking_mps2)

    def limit(x: float) -> float:
        vl = v_cruise
        if restr_at <= x <= restr_at + restr_len:
            vl = v_restr
        if x < restr_at:  # approach the restriction on a braking curve
            vl = min(vl, math.sqrt(v_restr**2 + 2 * a_brk * (restr_at - x)))
        return min(vl, math.sqrt(2 * a_brk * max(stop - x, 0.0)))

    return limit, a_acc, a_brk


def _wanted_accel(
    sc: Scenario, limit: Callable[[float], float], rates: tuple[float, float], s: float, v: float
) -> float:
    """The driver: towards the limit one second ahead; creep into the dead end."""
    a_acc, a_brk = rates
    wanted = sc.speed_gain_per_s * (limit(s + v) - v)
    return float(np.clip(wanted, -a_brk * sc.braking_reserve, a_acc))


def _drive(
    rng: np.random.Generator, stop: float, rate_hz: float, sc: Scenario
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """True motion: dwell, accelerate, cruise, restriction, brake, stop,
    stand.  Returns (t, s, v, a) at the sample times."""
    limit, a_acc, a_brk = _speed_limit(rng, stop, sc)
    dt = 1.0 / rate_hz
    rows: list[tuple[float, float, float, float]] = []
    s = -_uniform(rng, sc.start_before_first_m)
    v = a = t = 0.0
    stopped_at: float | None = None
    while t <= sc.max_duration_s and (stopped_at is None or t <= stopped_at + sc.stand_s):
        rows.append((t, s, v, a))
        a_des = 0.0
        if t >= sc.dwell_s:
            a_des = _wanted_accel(sc, limit, (a_acc, a_brk), s, v)
            if stop - s < sc.creep_m and v < sc.creep_mps:
                a_des = -sc.creep_mps2 if v > 0 else 0.0
        # Jerk-limited traction/brake response; the acceleration is linear
        # between samples, and speed and position are its exact integrals.
        a_new = a + (a_des - a) * dt / sc.response_s
        v_new = v + (a + a_new) / 2 * dt
        if v_new <= 0.0 and v > 0.0 or (v == 0.0 and a_new < 0.0):
            a_new = v_new = 0.0  # at rest within the step: hold still
            s += v * dt / 2
        else:
            s += v * dt + (2 * a + a_new) / 6 * dt * dt
        a, v, t = a_new, v_new, t + dt
        if t > sc.stopped_after_s and v == 0.0 and stopped_at is None:
            stopped_at = t
    arr = np.asarray(rows, dtype=np.float64)
    return arr[:, 0], arr[:, 1], arr[:, 2], arr[:, 3]


def _tunnels(
    rng: np.random.Generator, tt: FloatArray, tunnel_s: float, sc: Scenario
) -> tuple[list[tuple[float, float]], npt.NDArray[np.bool_]]:
    """Two or three tunnels; in half of the runs one more covers the stop."""
    duration = float(tt[-1])
    tunnels: list[tuple[float, float]] = []
    for _ in range(int(rng.integers(*sc.tunnels))):
        latest = max(2 * sc.first_tunnel_s, duration - sc.tunnel_room_s)
        st0 = rng.uniform(sc.first_tunnel_s, latest)
        tunnels.append((st0, st0 + tunnel_s))
    if rng.random() < sc.tunnel_over_stop_share:
        end = duration - rng.uniform(0, sc.tunnel_over_stop_end_s)
        tunnels.append((end - tunnel_s, end))
    ok = np.ones(tt.size, dtype=bool)
    for a0, a1 in tunnels:
        ok &= ~((tt >= a0) & (tt <= a1))
    return tunnels, ok


def _gnss(
    rng: np.random.Generator,
    truth: tuple[FloatArray, FloatArray, npt.NDArray[np.bool_]],
    geo: tuple[FloatArray, FloatArray, FloatArray],
    *,
    lag: int,
    every: int,
    speed_noise: float,
    pos_sigma: float,
    correlation_s: float,
) -> tuple[dict[int, float], dict[int, tuple[float, float]]]:
    """1 Hz GNSS speed and fix, measured ``lag`` samples before they are
    reported; fix errors are a Gauss–Markov process (``correlation_s``)."""
    ss, vv, ok = truth
    gs, glat, glon = geo
    gm = np.zeros(2)
    rho = math.exp(-1.0 / correlation_s)
    speed: dict[int, float] = {}
    fix: dict[int, tuple[float, float]] = {}
    lon_scale = EARTH_R * math.cos(math.radians(LAT0))
    for k in range(0, ss.size, every):
        gm = rho * gm + math.sqrt(1 - rho * rho) * rng.normal(0, pos_sigma, 2)
        km = k - lag
        if km < 0 or not ok[km] or not ok[k]:
            continue
        speed[k] = max(0.0, float(abs(vv[km]) + rng.normal(0, speed_noise)))
        lat = float(np.interp(ss[km], gs, glat)) + math.degrees(gm[1] / EARTH_R)
        lon = float(np.interp(ss[km], gs, glon)) + math.degrees(gm[0] / lon_scale)
        fix[k] = (lat, lon)
    return speed, fix


def _passes(table: MarkerTable, tt: FloatArray, ss: FloatArray) -> list[tuple[float, str, float]]:
    """(time, id, coordinate) of every marker the train passes (interpolated)."""
    out: list[tuple[float, str, float]] = []
    for m in table.markers:
        idx = np.nonzero((ss[:-1] < m.track_m) & (ss[1:] >= m.track_m))[0]
        if idx.size:
            i = int(idx[0])
            w = (m.track_m - ss[i]) / (ss[i + 1] - ss[i])
            out.append((float(tt[i] + w * (tt[i + 1] - tt[i])), m.id, m.track_m))
    return out


def _accelerometer(
    rng: np.random.Generator,
    table: MarkerTable,
    ss: FloatArray,
    aa: FloatArray,
    *,
    bias: float,
    noise: float,
) -> tuple[float, FloatArray]:
    """(the bias with its random sign, the readings at the sample positions)."""
    b = bias * (1 if rng.random() < 0.5 else -1)
    gr = np.array([table.gradient_at(x) for x in ss])
    # the accelerometer reads the specific force: gravity on the gradient too
    return b, aa + G * gr / PER_MILLE + b + rng.normal(0, noise, ss.size)


def generate_run(
    seed: int,
    *,
    delay_s: float = 2.0,
    bias: float = 0.02,
    accel_noise: float = 0.05,
    gnss_speed_noise: float = 0.03,
    gnss_pos_sigma: float = 8.0,
    tunnel_s: float = 60.0,
    rate_hz: float = 10.0,
    gradients: bool = True,
    scenario: Scenario = DEFAULT_SCENARIO,
) -> Run:
    """One run with a fixed seed (see the module documentation); sensor
    figures in SI units (``bias`` gets a random sign)."""
    sc = scenario
    rng = np.random.default_rng(seed)
    table, stop, geo = _line(rng, gradients, sc)
    tt, ss, vv, aa = _drive(rng, stop, rate_hz, sc)
    b, acc_meas = _accelerometer(rng, table, ss, aa, bias=bias, noise=accel_noise)
    tunnels, ok = _tunnels(rng, tt, tunnel_s, sc)
    gnss_speed, gnss_fix = _gnss(
        rng,
        (ss, vv, ok),
        geo,
        lag=int(round(delay_s * rate_hz)),
        every=int(round(rate_hz)),
        speed_noise=gnss_speed_noise,
        pos_sigma=gnss_pos_sigma,
        correlation_s=sc.fix_correlation_s,
    )
    passes = _passes(table, tt, ss)
    candidates = [p for p in passes if p[1] != "M00"] or passes
    missed = candidates[int(rng.integers(0, len(candidates)))][1]
    return Run(
        seed=seed,
        table=table,
        t=tt,
        s_true=ss,
        v_true=vv,
        accel_meas=acc_meas,
        gnss_ok=ok,
        gnss_speed=gnss_speed,
        gnss_fix=gnss_fix,
        marker_pass=passes,
        missed_id=missed,
        delay_s=delay_s,
        stop_m=stop,
        tunnels=tunnels,
        bias=b,
        start_estimate_m=float(ss[0] + rng.normal(0, sc.start_estimate_sigma_m)),
        accel_noise=accel_noise,
    )
