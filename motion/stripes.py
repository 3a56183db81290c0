"""Rolling-shutter images of vertical stripes: a renderer for tests and
benchmarks, and the smear meter working on real frames (seed ``000``,
section 2).  Re-exported by :mod:`motion.optical`.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any

import cv2
import numpy as np
import numpy.typing as npt

from .optical_limits import check_optical, check_rows, check_speed
from .ranging import KMH_PER_MPS
from .smear import speed_from_smear, speed_sigma_from_smear
from .stripes_quality import StripeQuality, check_agreement, check_quality
from .stripes_render import render_stripes

FloatArray = npt.NDArray[np.float64]

__all__ = [
    "OpticalSpeed",
    "SmearMeasurement",
    "StripeQuality",
    "measure_smear",
    "render_stripes",
    "speed_from_image",
]


@dataclass(frozen=True)
class SmearMeasurement:
    """The slant of vertical stripes measured on one rolling-shutter frame.

    ``slope`` is the along-track shift per row: in units of ``D`` (i.e. of
    ``tan θ``) per row when ``pixel_fov_rad`` was given, else pixels per row
    near the image centre.  ``smear_px`` is the paper's ``s`` over ``rows``
    rows, signed: with β known, ``tan(|s|·β) = |slope|·rows`` so that
    equation (14) returns ``D·|slope|/t_c`` exactly.
    """

    smear_px: float
    rows: int
    slope: float
    slope_sigma: float
    direction: int  # +1: the scene moves towards lower columns down the frame
    tracks: int
    points: int
    residual_px: float
    first_row: int
    last_row: int
    angular: bool = field(default=True)
    # the column model the edges followed: "equiangular" (column ∝ θ), "rectilinear"
    # (column ∝ tan θ: every edge shifts alike in pixels), "pixels" (no β given)
    lens: str = field(default="equiangular")


def _grey(image: npt.NDArray[Any]) -> FloatArray:
    """Grey levels as float64 (BGR, BGRA or single channel in)."""
    img = np.asarray(image)
    if img.ndim == 3:
        if img.shape[2] == 4:
            img = cv2.cvtColor(img, cv2.COLOR_BGRA2GRAY)
        elif img.shape[2] == 3:
            img = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
        else:
            img = img[:, :, 0]
    if img.ndim != 2 or img.shape[0] < 8 or img.shape[1] < 8:
        raise ValueError("expected a 2-D image of at least 8×8 pixels")
    g = np.asarray(img, dtype=np.float64)
    if not np.all(np.isfinite(g)):
        raise ValueError("image contains non-finite values")
    return g


def _stripe_band(
    g: FloatArray, contrast_fraction: float, min_rows: int
) -> tuple[int, int, int, FloatArray]:
    """The rows where the stripes are: the longest run of rows whose contrast
    reaches ``contrast_fraction`` of the best row.  Returns (first row, end
    row, run length, per-row threshold halfway between dark and bright)."""
    lo = np.percentile(g, 5, axis=1)
    hi = np.percentile(g, 95, axis=1)
    contrast = hi - lo
    best = float(contrast.max())
    if best <= 0:
        raise ValueError("no stripes: the image has no contrast")
    good = np.concatenate([[False], contrast >= contrast_fraction * best, [False]])
    edges = np.flatnonzero(np.diff(good.astype(np.int8)))
    starts, ends = edges[0::2], edges[1::2]
    k = int(np.argmax(ends - starts))
    run_start, run_len = int(starts[k]), int(ends[k] - starts[k])
    if run_len < min_rows:
        raise ValueError("no stripe band: too few rows with contrast")
    trim = min(3, run_len // 10)  # the soft top and bottom ends of the stripes
    r0, r1 = run_start + trim, run_start + run_len - trim
    return r0, r1, run_len, (lo[r0:r1] + hi[r0:r1]) / 2


def _crossings(
    band: FloatArray, thr: FloatArray
) -> tuple[npt.NDArray[np.intp], FloatArray, npt.NDArray[np.int8]]:
    """Sub-pixel threshold crossings along each row: (row index, column, polarity)."""
    d = band - thr[:, None]
    pos = d >= 0
    r, c = np.nonzero(pos[:, 1:] != pos[:, :-1])
    a = d[r, c]
    b = d[r, c + 1]
    col = c + a / (a - b)
    pol = np.where(b > a, 1, -1).astype(np.int8)
    return r, col, pol


def _follow_edges(
    rr: npt.NDArray[np.intp], uu: FloatArray, pp: npt.NDArray[np.int8], nrows: int, gate: float
) -> list[list[tuple[int, float]]]:
    """Follow every edge from row to row: each track takes the nearest crossing
    of its polarity around the position its slope predicts, within ``gate``."""
    starts = np.searchsorted(rr, np.arange(nrows + 1))
    last: list[float] = []
    last_row: list[int] = []
    slope: list[float] = []
    pol: list[int] = []
    pts: list[list[tuple[int, float]]] = []
    for r in range(nrows):
        ru = uu[starts[r] : starts[r + 1]]
        rp = pp[starts[r] : starts[r + 1]]
        used = np.zeros(ru.size, dtype=bool)
        for ti in range(len(last)):
            if r - last_row[ti] > 3:
                continue
            cand = np.nonzero((rp == pol[ti]) & ~used)[0]
            if cand.size == 0:
                continue
            pred = last[ti] + slope[ti] * (r - last_row[ti])
            j = cand[np.argmin(np.abs(ru[cand] - pred))]
            if abs(ru[j] - pred) > gate:
                continue
            used[j] = True
            p = pts[ti]
            p.append((r, float(ru[j])))
            # slope over the last ≤ 30 rows: local, so curved tracks follow too
            r_old, u_old = p[max(0, len(p) - 31)]
            if r > r_old:
                slope[ti] = (p[-1][1] - u_old) / (r - r_old)
            last[ti], last_row[ti] = float(ru[j]), r
        for j in np.nonzero(~used)[0]:
            last.append(float(ru[j]))
            last_row.append(r)
            slope.append(0.0)
            pol.append(int(rp[j]))
            pts.append([(r, float(ru[j]))])
    return pts


def _combine_tracks(
    tracks: list[list[tuple[int, float]]], min_rows: int
) -> tuple[float, float, int, int, float]:
    """Straight-line fit per track; the point-weighted mean of the slopes that
    agree with their median.  Returns (slope, its σ, tracks, points, rms)."""
    fits: list[tuple[float, int, float]] = []
    for pts in tracks:
        if len(pts) < min_rows:
            continue
        arr = np.asarray(pts)
        k, c0 = np.polyfit(arr[:, 0], arr[:, 1], 1)
        res = arr[:, 1] - (k * arr[:, 0] + c0)
        fits.append((float(k), len(pts), float(np.sqrt(np.mean(res**2)))))
    if not fits:
        raise ValueError("no stripe edge could be followed over enough rows")
    ks = np.array([f[0] for f in fits])
    ns = np.array([f[1] for f in fits], dtype=np.float64)
    rs = np.array([f[2] for f in fits])
    med = float(np.median(ks))
    mad = float(np.median(np.abs(ks - med)))
    ok = np.abs(ks - med) <= max(4 * 1.4826 * mad, 0.02 * abs(med), 1e-9)
    ks, ns, rs = ks[ok], ns[ok], rs[ok]
    slope = float(np.sum(ks * ns) / np.sum(ns))
    sigma = (
        float(np.sqrt(np.sum(ns * (ks - slope) ** 2) / np.sum(ns) / (ks.size - 1)))
        if ks.size > 1
        else float("nan")
    )
    rms = float(np.sqrt(np.sum(ns * rs**2) / np.sum(ns)))
    return slope, sigma, int(ks.size), int(ns.sum()), rms


# The rectilinear model is taken only when its edges agree on one slope this many times
# better than the equiangular one's (relative spread): where the two are alike (a narrow
# field, a standing train) the paper's model stays.
_LENS_MARGIN = 2.0
Fit = tuple[float, float, int, int, float]


def _lens_fit(
    tracks: list[list[tuple[int, float]]],
    angular: Fit,
    cx: float,
    beta: float,
    min_rows: int,
    quality: StripeQuality,
) -> tuple[Fit, str]:
    """The fit in the lens model the frame follows, and its name.

    A rolling shutter shifts every edge alike in the lens's linear coordinate:
    ``tan θ`` for an equiangular lens (``angular``, measured in units of D), the
    column itself for a rectilinear one.  Measuring a rectilinear frame in
    ``tan θ`` biased the smear by the mean ``sec² θ`` of its edges (17 % across
    1400 px at 0.94 mrad, found by the independent trial).  The same edge
    tracks are fitted in pixels; that fit is used (turned into units of D,
    ``x/D = (c - cx)·β``) when its slopes agree clearly better and it passes the
    stripe gate itself.  The gate on ``angular`` has been passed already.
    """
    px_tracks = [[(r, cx + math.atan(u) / beta) for r, u in t] for t in tracks]
    try:
        px = _combine_tracks(px_tracks, min_rows)
    except ValueError:
        return angular, "equiangular"

    def spread(f: Fit) -> float:
        return f[1] / abs(f[0]) if math.isfinite(f[1]) and f[0] != 0 else math.inf

    passes = px[2] >= quality.min_tracks and px[4] <= quality.max_residual_px
    if not passes or _LENS_MARGIN * spread(px) >= spread(angular):
        return angular, "equiangular"
    slope, sigma, n_tracks, n_points, rms_px = px
    return (slope * beta, sigma * beta, n_tracks, n_points, rms_px * beta), "rectilinear"


def measure_smear(
    image: npt.NDArray[Any],
    *,
    pixel_fov_rad: float | None = None,
    rows: int | None = None,
    center_col: float | None = None,
    smooth_px: float = 1.0,
    min_track_rows: int = 40,
    contrast_fraction: float = 0.5,
    quality: StripeQuality = StripeQuality(),
) -> SmearMeasurement:
    """Measure the rolling-shutter slant of vertical stripes on ``image``.

    Parameters
    ----------
    image : ndarray, shape (H, W) or (H, W, 3|4) BGR(A)
        One frame, rows read out top to bottom.
    pixel_fov_rad : float, optional
        β, the angle of one pixel.  With it the edge columns are turned into
        along-track positions ``tan((c - cx)·β)`` (units of D), which the
        rolling shutter moves by exactly ``v·t_c/D`` per row anywhere in the
        frame; without it slopes are in pixels per row (small angles).
    rows : int, optional
        h for the smear figure; defaults to the height of the stripe band.
    center_col : float, optional
        Column of the optical axis; defaults to the image centre.
    quality : StripeQuality
        Below it: ``ValueError("no stripes found ...")``, not a speed.

    Steps: the band of rows with stripes; in every row the sub-pixel
    crossings of the level halfway between the row's dark and bright levels
    (rising and falling edges apart); edges followed from row to row; a
    straight line per edge; the point-weighted mean of the edge slopes that
    agree with their median.
    """
    g = _grey(image)
    if smooth_px > 0:
        # along rows only: rows are different instants
        k = int(2 * math.ceil(3 * smooth_px) + 1)
        g = np.asarray(cv2.GaussianBlur(g, (k, 1), smooth_px, sigmaY=1e-6), dtype=np.float64)
    width = g.shape[1]
    r0, r1, band_rows, thr = _stripe_band(g, contrast_fraction, min_track_rows)
    rr, cc, pp = _crossings(g[r0:r1], thr)
    keep = (cc > 1) & (cc < width - 2)  # not at the image border
    rr, cc, pp = rr[keep], cc[keep], pp[keep]
    if rr.size == 0:
        raise ValueError("no stripe edges found")
    cx = (width - 1) / 2.0 if center_col is None else float(center_col)
    if pixel_fov_rad is not None:
        ang = (cc - cx) * pixel_fov_rad
        if np.any(np.abs(ang) >= math.pi / 2):
            raise ValueError("pixel field of view too large for the image width")
        uu, px_scale = np.tan(ang), pixel_fov_rad
    else:
        uu, px_scale = cc.copy(), 1.0
    # gate: a quarter of the typical same-polarity edge spacing
    sp = [
        float(np.median(np.diff(uu[(rr == r) & (pp > 0)])))
        for r in range(0, r1 - r0, 25)
        if np.count_nonzero((rr == r) & (pp > 0)) > 1
    ]
    gate = 0.25 * float(np.median(sp)) if sp else 40.0 * px_scale
    tracks = _follow_edges(rr, uu, pp, r1 - r0, gate)
    fit = _combine_tracks(tracks, min_track_rows)
    # The gate first, as measured: a frame refused here stays refused whatever the lens.
    check_quality(fit[2], fit[4] / px_scale, quality)
    lens = "pixels"
    if pixel_fov_rad is not None:
        fit, lens = _lens_fit(tracks, fit, cx, pixel_fov_rad, min_track_rows, quality)
    slope, slope_sigma, n_tracks, n_points, rms = fit
    h = int(rows) if rows is not None else band_rows
    band_px = (r1 - r0) / px_scale  # the spread of the slope over the band, in pixels
    check_agreement(slope * band_px, slope_sigma * band_px, quality)
    if pixel_fov_rad is not None:
        smear = math.copysign(math.atan(abs(slope) * h) / pixel_fov_rad, -slope)
    else:
        smear = -slope * h
    return SmearMeasurement(
        smear_px=smear,
        rows=h,
        slope=slope,
        slope_sigma=slope_sigma,
        direction=1 if slope < 0 else (-1 if slope > 0 else 0),
        tracks=n_tracks,
        points=n_points,
        residual_px=rms / px_scale,
        first_row=r0,
        last_row=r1 - 1,
        angular=pixel_fov_rad is not None,
        lens=lens,
    )


@dataclass(frozen=True)
class OpticalSpeed:
    """Speed measured on one image, ready for JSON."""

    speed_mps: float
    speed_kmh: float
    sigma_mps: float  # eq. (15), the pixel discreteness Δω
    sigma_kmh: float
    fit_sigma_mps: float  # spread of the stripe-track slopes
    smear_px: float
    rows: int
    direction: int
    tracks: int
    residual_px: float

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


def speed_from_image(
    image: npt.NDArray[Any],
    *,
    distance_m: float,
    pixel_fov_rad: float,
    row_time_s: float,
    rows: int | None = None,
    pixel_error_rad: float | None = None,
    center_col: float | None = None,
) -> OpticalSpeed:
    """Measure the smear on ``image`` (:func:`measure_smear`) and turn it into
    a signed speed with equation (14) and its uncertainty with (15).

    Inputs outside :data:`~motion.optical_limits.OPTICAL_LIMITS`, ``rows`` beyond the
    frame, and a speed beyond any train are refused
    (:class:`~motion.optical_limits.OpticalRangeError`)."""
    check_optical(distance_m, pixel_fov_rad, row_time_s, pixel_error_rad)
    if rows is not None:
        check_rows(rows, int(np.asarray(image).shape[0]))
    m = measure_smear(image, pixel_fov_rad=pixel_fov_rad, rows=rows, center_col=center_col)
    geom = {
        "distance_m": distance_m,
        "pixel_fov_rad": pixel_fov_rad,
        "rows": m.rows,
        "row_time_s": row_time_s,
    }
    v = speed_from_smear(m.smear_px, **geom)
    sig = speed_sigma_from_smear(m.smear_px, **geom, pixel_error_rad=pixel_error_rad)
    check_speed(v)
    fit_sig = distance_m * m.slope_sigma / row_time_s if math.isfinite(m.slope_sigma) else sig
    return OpticalSpeed(
        speed_mps=v,
        speed_kmh=v * KMH_PER_MPS,
        sigma_mps=sig,
        sigma_kmh=sig * KMH_PER_MPS,
        fit_sigma_mps=fit_sig,
        smear_px=m.smear_px,
        rows=m.rows,
        direction=m.direction,
        tracks=m.tracks,
        residual_px=m.residual_px,
    )
