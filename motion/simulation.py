"""Generated train runs for testing and benchmarking :mod:`motion.fusion`.

A run (fixed seed) is a line with curves and gradients, track markers every
1–2 km with geographic positions, and a train that starts from a station,
accelerates, cruises (with a speed restriction on the way), brakes and
stops at a dead end.  On board:

* accelerometer at 10 Hz on the car's axis: specific force (gravity on the
  gradient included) + a bias of ±0.02 m/s² + white noise 0.05 m/s²;
* GNSS speed at 1 Hz, 2 s late, noise 0.03 m/s; GNSS fixes at 1 Hz, 2 s
  late, error a Gauss–Markov process of 8 m per axis (60 s correlation);
  both lost for 60 s in each tunnel (two or three tunnels per run, one
  of them, in half of the runs, over the final stop);
* a marker reader that reads a marker when the train passes it *and the
  filter has the reader switched on*; one marker per run is never read.
  A read produces an extra sample at the instant of the read.

:func:`run_fusion` feeds the events to a :class:`~motion.fusion.TrackFilter`
in a closed loop (the reader follows ``reader_on``);
:func:`dead_reckoning` and :func:`gnss_only` are the baselines;
:func:`evaluate` reports the final-stop errors of all three.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from .fusion import FilterConfig, G, Marker, MarkerTable, TrackFilter, TrackState

__all__ = [
    "FusionReport",
    "Run",
    "dead_reckoning",
    "evaluate",
    "generate_run",
    "gnss_only",
    "run_fusion",
]

FloatArray = npt.NDArray[np.float64]
LAT0, LON0 = 50.4501, 30.5234
EARTH_R = 6_371_000.0


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


def _geometry(length: float, rng: np.random.Generator) -> tuple[FloatArray, FloatArray, FloatArray]:
    """A curved line: coordinate every 10 m → (s, lat, lon)."""
    ds = 10.0
    n = int(length / ds) + 2
    s = np.arange(n, dtype=np.float64) * ds
    curv = np.zeros(n)
    pos = 0.0
    while pos < length:
        seg = rng.uniform(500, 2000)
        k = 0.0 if rng.random() < 0.4 else rng.choice([-1, 1]) / rng.uniform(800, 4000)
        curv[(s >= pos) & (s < pos + seg)] = k
        pos += seg
    heading = np.cumsum(curv) * ds + rng.uniform(0, 2 * math.pi)
    x = np.concatenate([[0.0], np.cumsum(np.cos(heading[:-1]) * ds)])
    y = np.concatenate([[0.0], np.cumsum(np.sin(heading[:-1]) * ds)])
    lat = LAT0 + np.degrees(y / EARTH_R)
    lon = LON0 + np.degrees(x / (EARTH_R * math.cos(math.radians(LAT0))))
    return s, lat, lon


def _line(
    rng: np.random.Generator, gradients: bool
) -> tuple[MarkerTable, float, tuple[FloatArray, FloatArray, FloatArray]]:
    """Markers every 1–2 km, the dead end after the last one, a curved line
    with gradients.  Returns (table, stop coordinate, dense geometry)."""
    coords = [0.0]
    for _ in range(int(rng.integers(5, 9)) - 1):
        coords.append(coords[-1] + rng.uniform(1000, 2000))
    stop = coords[-1] + rng.uniform(300, 1500)
    length = stop + 200
    gs, glat, glon = _geometry(length, rng)
    markers = [
        Marker(f"M{k:02d}", c, float(np.interp(c, gs, glat)), float(np.interp(c, gs, glon)))
        for k, c in enumerate(coords)
    ]
    grad_pts: list[tuple[float, float]] = []
    pos = 0.0
    while gradients and pos < length:
        grad_pts.append((pos, float(rng.uniform(-8, 8))))
        pos += rng.uniform(500, 2000)
    geometry = [
        (float(a), float(b), float(c))
        for a, b, c in zip(gs[::20], glat[::20], glon[::20], strict=True)
    ]
    return MarkerTable(markers, gradients=grad_pts, geometry=geometry), stop, (gs, glat, glon)


def _speed_limit(rng: np.random.Generator, stop: float) -> tuple[Any, float, float]:
    """A line speed, a restriction on the way and the braking curve to the
    dead end.  Returns (limit(x), traction acceleration, braking rate)."""
    v_cruise = rng.uniform(15, 25)
    restr_at = rng.uniform(0.3, 0.6) * stop
    restr_len = rng.uniform(300, 800)
    v_restr = rng.uniform(8, 12)
    a_acc = rng.uniform(0.6, 1.0)
    a_brk = rng.uniform(0.5, 0.8)

    def limit(x: float) -> float:
        vl = v_cruise
        if restr_at <= x <= restr_at + restr_len:
            vl = v_restr
        if x < restr_at:  # approach the restriction on a braking curve
            vl = min(vl, math.sqrt(v_restr**2 + 2 * a_brk * (restr_at - x)))
        return min(vl, math.sqrt(2 * a_brk * max(stop - x, 0.0)))

    return limit, a_acc, a_brk


def _drive(
    rng: np.random.Generator, stop: float, rate_hz: float
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """True motion: dwell, accelerate, cruise, restriction, brake, stop,
    stand 15 s.  Returns (t, s, v, a) at the sample times."""
    limit, a_acc, a_brk = _speed_limit(rng, stop)
    dt = 1.0 / rate_hz
    rows: list[tuple[float, float, float, float]] = []
    s = -float(rng.uniform(100, 400))  # the station track before the first marker
    v = a = t = 0.0
    stopped_at: float | None = None
    while t <= 4000 and (stopped_at is None or t <= stopped_at + 15.0):
        rows.append((t, s, v, a))
        a_des = 0.0
        if t >= 10.0:  # dwell, then drive to the limit
            a_des = float(np.clip(0.8 * (limit(s + v) - v), -a_brk * 1.05, a_acc))
            if stop - s < 0.3 and v < 0.3:
                a_des = -0.3 if v > 0 else 0.0
        # Jerk-limited traction/brake response; the acceleration is linear
        # between samples, and speed and position are its exact integrals.
        a_new = a + (a_des - a) * dt / 0.8
        v_new = v + (a + a_new) / 2 * dt
        if v_new <= 0.0 and v > 0.0 or (v == 0.0 and a_new < 0.0):
            a_new = v_new = 0.0  # at rest within the step: hold still
            s += v * dt / 2
        else:
            s += v * dt + (2 * a + a_new) / 6 * dt * dt
        a, v, t = a_new, v_new, t + dt
        if t > 15.0 and v == 0.0 and stopped_at is None:
            stopped_at = t
    arr = np.asarray(rows, dtype=np.float64)
    return arr[:, 0], arr[:, 1], arr[:, 2], arr[:, 3]


def _tunnels(
    rng: np.random.Generator, tt: FloatArray, tunnel_s: float
) -> tuple[list[tuple[float, float]], npt.NDArray[np.bool_]]:
    """Two or three tunnels; in half of the runs one more covers the stop."""
    duration = float(tt[-1])
    tunnels: list[tuple[float, float]] = []
    for _ in range(int(rng.integers(2, 4))):
        st0 = rng.uniform(30, max(60.0, duration - 200))
        tunnels.append((st0, st0 + tunnel_s))
    if rng.random() < 0.5:
        end = duration - rng.uniform(0, 20)
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
) -> tuple[dict[int, float], dict[int, tuple[float, float]]]:
    """1 Hz GNSS speed and fix, measured ``lag`` samples before they are
    reported; fix errors are a Gauss–Markov process (60 s correlation)."""
    ss, vv, ok = truth
    gs, glat, glon = geo
    gm = np.zeros(2)
    rho = math.exp(-1.0 / 60.0)
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
) -> Run:
    """One run with a fixed seed (see the module documentation)."""
    rng = np.random.default_rng(seed)
    table, stop, geo = _line(rng, gradients)
    tt, ss, vv, aa = _drive(rng, stop, rate_hz)
    b = bias * (1 if rng.random() < 0.5 else -1)
    gr = np.array([table.gradient_at(x) for x in ss])
    # the accelerometer reads the specific force: gravity on the gradient too
    acc_meas = aa + G * gr / 1000.0 + b + rng.normal(0, accel_noise, tt.size)
    tunnels, ok = _tunnels(rng, tt, tunnel_s)
    gnss_speed, gnss_fix = _gnss(
        rng,
        (ss, vv, ok),
        geo,
        lag=int(round(delay_s * rate_hz)),
        every=int(round(rate_hz)),
        speed_noise=gnss_speed_noise,
        pos_sigma=gnss_pos_sigma,
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
        start_estimate_m=float(ss[0] + rng.normal(0, 3.0)),
        accel_noise=accel_noise,
    )


def run_fusion(
    run: Run,
    config: FilterConfig | None = None,
    *,
    use_markers: bool = True,
    use_fixes: bool = True,
    use_speed: bool = True,
    record: bool = False,
) -> tuple[TrackState, list[TrackState], int]:
    """Feed the run to a filter; the reader reads a marker only while
    ``reader_on``.  Returns (final state, states if ``record``, markers read)."""
    cfg = config or FilterConfig(
        initial_position_m=run.start_estimate_m,
        gnss_delay_s=run.delay_s,
        accel_noise_mps2=run.accel_noise,
    )
    f = TrackFilter(run.table, cfg)
    passes = sorted(run.marker_pass) if use_markers else []
    pi = 0
    states: list[TrackState] = []
    reads = 0
    st: TrackState | None = None
    t = run.t
    acc = run.accel_meas
    for k in range(t.size):
        # marker reads that happened since the previous sample
        while pi < len(passes) and passes[pi][0] <= t[k]:
            tp, mid, _ = passes[pi]
            pi += 1
            if mid == run.missed_id or tp <= (st.t if st else -1.0):
                continue
            if st is not None and not st.reader_on:
                continue
            w = (tp - t[k - 1]) / (t[k] - t[k - 1]) if k else 0.0
            a_at = float(acc[k - 1] + w * (acc[k] - acc[k - 1])) if k else float(acc[0])
            st = f.step(tp, a_at, marker_id=mid)
            reads += 1
            if record:
                states.append(st)
        gs = run.gnss_speed.get(k) if use_speed else None
        fx = run.gnss_fix.get(k) if use_fixes else None
        st = f.step(
            float(t[k]),
            float(acc[k]),
            gs,
            run.delay_s if gs is not None or fx is not None else None,
            None,
            fx[0] if fx else None,
            fx[1] if fx else None,
        )
        if record:
            states.append(st)
    assert st is not None
    return st, states, reads


def dead_reckoning(run: Run) -> float:
    """Baseline: accelerometer integrated twice from the known start, the
    gradient removed with the track profile, the bias unknown."""
    t = run.t
    a = run.accel_meas
    s = run.start_estimate_m
    v = 0.0
    for k in range(1, t.size):
        dt = t[k] - t[k - 1]
        gi = G * run.table.gradient_at(s) / 1000.0
        a0 = a[k - 1] - gi
        a1 = a[k] - gi
        s += v * dt + (2 * a0 + a1) / 6 * dt * dt
        v += (a0 + a1) / 2 * dt
    return s


def gnss_only(run: Run) -> float:
    """Baseline: the newest GNSS fix projected on the track, advanced by the
    newest GNSS speed over its age (delay included); the start if none."""
    last_s: float | None = None
    last_v = 0.0
    last_t = 0.0
    for k in sorted(run.gnss_fix):
        lat, lon = run.gnss_fix[k]
        s_fix, _ = run.table.project(lat, lon)
        last_s = s_fix
        last_v = run.gnss_speed.get(k, last_v)
        last_t = float(run.t[k]) - run.delay_s
    if last_s is None:
        return 0.0
    return last_s + last_v * (float(run.t[-1]) - last_t)


@dataclass(frozen=True)
class FusionReport:
    runs: int
    threshold_m: float
    fusion_errors_m: list[float]
    dead_reckoning_errors_m: list[float]
    gnss_only_errors_m: list[float]
    fusion_sigma_m: list[float]
    markers_read: list[int]

    @staticmethod
    def _stats(e: list[float], thr: float) -> dict[str, float]:
        a = np.abs(np.asarray(e))
        return {
            "within_threshold": float(np.mean(a <= thr)),
            "median_m": float(np.median(a)),
            "p95_m": float(np.percentile(a, 95)),
            "max_m": float(a.max()),
        }

    def summary(self) -> dict[str, dict[str, float]]:
        thr = self.threshold_m
        z = np.abs(np.asarray(self.fusion_errors_m)) / np.maximum(
            np.asarray(self.fusion_sigma_m), 1e-9
        )
        fus = self._stats(self.fusion_errors_m, thr)
        fus["within_3_sigma"] = float(np.mean(z <= 3.0))
        return {
            "fusion": fus,
            "dead_reckoning": self._stats(self.dead_reckoning_errors_m, thr),
            "gnss_only": self._stats(self.gnss_only_errors_m, thr),
        }


def evaluate(seeds: range | list[int], threshold_m: float = 5.0, **run_kw: Any) -> FusionReport:
    """Final-stop position errors of the filter and both baselines."""
    fe: list[float] = []
    de: list[float] = []
    ge: list[float] = []
    sg: list[float] = []
    rd: list[int] = []
    for seed in seeds:
        run = generate_run(seed, **run_kw)
        st, _, reads = run_fusion(run)
        truth = run.final_position
        fe.append(st.position_m - truth)
        sg.append(st.sigma_position_m)
        rd.append(reads)
        de.append(dead_reckoning(run) - truth)
        ge.append(gnss_only(run) - truth)
    return FusionReport(len(fe), threshold_m, fe, de, ge, sg, rd)
