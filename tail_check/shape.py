"""Disc-consistency checks on connected regions of the colour mask.

All measures are scale-free (ratios), so they do not depend on the image size.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from .profile import CameraProfile

__all__ = ["CUT_SOLIDITY", "CutDisc", "RegionShape", "cut_members", "measure_region", "ramp"]

# Membership ramps of a disc cut by a straight edge: fit overlap, arc and edge
# residuals, visible share of the whole ellipse, solidity (a cut disc is convex).
CUT_IOU = (0.86, 0.92)
CUT_ARC = (0.045, 0.065)
CUT_EDGE = (0.04, 0.08)
CUT_VISIBLE = (0.45, 0.65)
CUT_SOLIDITY = (0.86, 0.92)
ARC_FIT_ROUNDS = 12
WHOLE_RESIDUAL = 0.03
"""Hull residual below which a region is a whole ellipse (no cut-disc fit needed)."""
"""Refits of the arc ellipse; a deep cut needs several to stop pulling the fit in."""


@dataclass(frozen=True)
class CutDisc:
    """Fit of a region as an ellipse with one side hidden behind a straight edge.

    A pole or signal post in front of the car cuts the disc along a straight line:
    the rest of the outline is still an elliptic arc, and the region is the ellipse
    on one side of that line.

    Attributes
    ----------
    diameter : float
        Equivalent-circle diameter of the whole fitted ellipse, pixels.
    aspect : float
        Major / minor axis of the fitted ellipse, >= 1.
    visible : float
        Region (hull) area / area of the whole fitted ellipse.
    iou : float
        Overlap of the region's hull with the fitted ellipse cut at the edge line.
    arc_residual : float
        RMS relative deviation of the arc points from the fitted ellipse.
    edge_residual : float
        RMS distance of the cut points from their straight line, in radii.
    edge_point, edge_direction : tuple of 2 float
        A point of the edge line (in the region's box coordinates) and its unit direction.
    hidden_normal : tuple of 2 float
        Unit normal of the edge line pointing to the hidden side.
    span : tuple of 2 float
        Extent of the cut along the edge line, from ``edge_point``.
    """

    diameter: float
    aspect: float
    visible: float
    iou: float
    arc_residual: float
    edge_residual: float
    edge_point: tuple[float, float] = (0.0, 0.0)
    edge_direction: tuple[float, float] = (0.0, 1.0)
    hidden_normal: tuple[float, float] = (1.0, 0.0)
    span: tuple[float, float] = (0.0, 0.0)


@dataclass(frozen=True)
class RegionShape:
    """Shape measures of one region (holes filled, e.g. the reflector).

    Attributes
    ----------
    area : float
        Filled area in pixels of the analysed image.
    fill : float
        Convex-hull area / bounding-box area (a disc: π/4 ≈ 0.785, a box: 1).
    ellipse_iou : float
        Overlap of the convex hull with the ellipse of equal second moments
        (a disc ≈ 1, a box ≈ 0.83).
    solidity : float
        Area / convex-hull area (a disc ≈ 1; logos, rings, letters less).
    aspect : float
        Long / short side of the bounding box, >= 1.
    hole_fraction : float
        Share of the filled area that the region itself does not cover (a disc with
        its reflector: a few percent; a ring or hand wheel: most of it).
    ellipse_residual : float
        RMS relative deviation of the hull outline from the moment ellipse (a digitised
        disc: < 0.05; a box or rounded box: about 0.08-0.12).
    large_holes : int
        Holes of more than 2 % of the area each (a disc: its reflector at most; a
        hand wheel: the sectors between its spokes).
    holes : int
        Holes of more than 0.4 % of the area each (a disc: its reflector and a few
        specks of dirt or snow; a hand wheel: a hole between each pair of spokes).
    """

    area: float
    fill: float
    ellipse_iou: float
    solidity: float
    aspect: float
    hole_fraction: float
    ellipse_residual: float
    large_holes: int = 0
    cut: CutDisc | None = None
    holes: int = 0


def ramp(x: float, lo0: float, lo1: float, hi1: float = math.inf, hi0: float = math.inf) -> float:
    """Trapezoid membership: 0 below ``lo0``, 1 on ``[lo1, hi1]``, 0 above ``hi0``."""
    if x <= lo0 or x >= hi0:
        return 0.0
    if x < lo1:
        return (x - lo0) / (lo1 - lo0)
    if x > hi1:
        return (hi0 - x) / (hi0 - hi1)
    return 1.0


def median(values: NDArray[np.floating]) -> float:
    """``np.median`` of a 1-D array (the same value), without its generic machinery."""
    n = len(values)
    half = n // 2
    if n % 2:
        return float(np.partition(values, half)[half])
    part = np.partition(values, (half - 1, half))
    return float((part[half - 1] + part[half]) / 2.0)


def _moment_ellipse(
    filled: NDArray[np.uint8], outline: NDArray[np.int32]
) -> tuple[NDArray[np.uint8], float]:
    """The filled ellipse with the same centroid and second moments as ``filled``,
    and the RMS relative deviation of ``outline`` from that ellipse's shape."""
    m = cv2.moments(filled, binaryImage=True)
    if m["m00"] <= 0:
        return np.zeros_like(filled), 1.0
    cx, cy = m["m10"] / m["m00"], m["m01"] / m["m00"]
    cov = np.array([[m["mu20"], m["mu11"]], [m["mu11"], m["mu02"]]]) / m["m00"]
    evals, evecs = np.linalg.eigh(cov)
    pts = outline.reshape(-1, 2).astype(np.float64) - (cx, cy)
    inv = np.linalg.inv(cov + np.eye(2) * 1e-9)
    rho = np.sqrt(np.einsum("ni,ij,nj->n", pts, inv, pts))
    # Normalised by the median: the digital outline runs half a pixel inside the edge.
    residual = float(np.sqrt(np.mean((rho / max(median(rho), 1e-9) - 1.0) ** 2)))
    evals = np.maximum(evals, 1e-6)
    # A uniform filled ellipse with semi-axis a has variance a²/4 along that axis.
    minor, major = 2.0 * math.sqrt(evals[0]), 2.0 * math.sqrt(evals[1])
    angle = math.degrees(math.atan2(evecs[1, 1], evecs[0, 1]))
    out = np.zeros_like(filled)
    shift = 4
    cv2.ellipse(
        out,
        (round(cx * (1 << shift)), round(cy * (1 << shift))),
        (round(major * (1 << shift)), round(minor * (1 << shift))),
        angle,
        0,
        360,
        1,
        thickness=-1,
        lineType=cv2.LINE_8,
        shift=shift,
    )
    return out, residual


Ellipse = tuple[tuple[float, float], tuple[float, float], float]
"""An OpenCV rotated ellipse: centre, full axes, angle in degrees."""


def _fit_ellipse(pts: NDArray[np.float32]) -> Ellipse:
    """Least-squares ellipse through the points, as plain floats."""
    (cx, cy), (d1, d2), angle = cv2.fitEllipse(pts)
    return (float(cx), float(cy)), (float(d1), float(d2)), float(angle)


def _ellipse_rho(pts: NDArray[np.float32], box: Ellipse) -> NDArray[np.float64]:
    """Normalised radial distance of points from an OpenCV rotated ellipse (1 on it)."""
    (cx, cy), (d1, d2), angle = box
    t = math.radians(angle)
    dx, dy = pts[:, 0] - cx, pts[:, 1] - cy
    u = (dx * math.cos(t) + dy * math.sin(t)) / max(d1 / 2.0, 1e-6)
    v = (-dx * math.sin(t) + dy * math.cos(t)) / max(d2 / 2.0, 1e-6)
    return np.asarray(np.sqrt(u * u + v * v), dtype=np.float64)


def _arc_fit(pts: NDArray[np.float32]) -> tuple[Ellipse, NDArray[np.bool_]]:
    """Ellipse through the outline's arc: points well inside the fit are dropped and the
    ellipse refitted, so a straight cut does not pull it in. Returns the fit and the
    mask of the points on the arc."""
    keep = np.ones(len(pts), bool)
    box = _fit_ellipse(pts)
    for _ in range(ARC_FIT_ROUNDS):
        radius = 0.25 * (box[1][0] + box[1][1])
        new = _ellipse_rho(pts, box) >= 1.0 - max(0.04, 1.0 / max(radius, 1.0))
        if np.array_equal(new, keep) or np.count_nonzero(new) < 8:
            break
        keep = new
        box = _fit_ellipse(pts[keep])
    return box, keep


def _longest_run(flags: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """The longest run of True in a closed (circular) sequence, as a mask."""
    n = len(flags)
    if flags.all() or not flags.any():
        return flags.copy()
    start = int(np.argmin(flags))  # a False: runs do not wrap past it
    rolled = np.roll(flags, -start)
    edges = np.diff(np.concatenate(([0], rolled.view(np.int8), [0])))
    begins, ends = np.nonzero(edges == 1)[0], np.nonzero(edges == -1)[0]
    k = int(np.argmax(ends - begins))
    out = np.zeros(n, bool)
    out[begins[k] : ends[k]] = True
    return np.roll(out, start)


def _fit_cut(hull_img: NDArray[np.uint8], outline: NDArray[np.int32], pad: int) -> CutDisc | None:
    """Fit the hull as an ellipse cut by one straight edge (see :class:`CutDisc`)."""
    pts = outline.reshape(-1, 2).astype(np.float32)
    if len(pts) < 16:
        return None
    box, keep = _arc_fit(pts)
    cut = _longest_run(~keep)
    # One run of cut points, long enough to be an edge and not noise, holding nearly
    # all points off the arc (dirt and JPEG dent the arc in short runs).
    if np.count_nonzero(cut) < max(4, 0.08 * len(pts)) or np.count_nonzero(keep) < 8:
        return None
    if np.count_nonzero(cut) < 0.8 * np.count_nonzero(~keep):
        return None
    (d1, d2) = box[1]
    if min(d1, d2) < 2.0:
        return None
    radius = 0.25 * (d1 + d2)
    line = cv2.fitLine(pts[cut], cv2.DIST_L2, 0, 0.01, 0.01).ravel()
    vx, vy, x0, y0 = (float(v) for v in line)
    side = (pts[:, 0] - x0) * -vy + (pts[:, 1] - y0) * vx
    edge_residual = float(np.sqrt(np.mean(side[cut] ** 2))) / radius
    arc_residual = float(np.sqrt(np.mean((_ellipse_rho(pts[keep], box) - 1.0) ** 2)))
    ellipse = np.zeros_like(hull_img)
    cv2.ellipse(ellipse, box, 1, thickness=-1)
    full = float(np.count_nonzero(ellipse))
    # The visible side of the edge line is the side of the arc points.
    sign = 1.0 if float(np.median(side[keep])) >= 0 else -1.0
    yy, xx = np.indices(hull_img.shape, dtype=np.float32)
    half = (sign * ((xx - x0) * -vy + (yy - y0) * vx) >= -0.5).view(np.uint8)
    visible_ellipse = ellipse & half
    union = float(np.count_nonzero(visible_ellipse | hull_img))
    inter = float(np.count_nonzero(visible_ellipse & hull_img))
    along = (pts[cut, 0] - x0) * vx + (pts[cut, 1] - y0) * vy
    return CutDisc(
        edge_point=(x0 - pad, y0 - pad),
        edge_direction=(vx, vy),
        hidden_normal=(sign * vy, -sign * vx),
        span=(float(along.min()), float(along.max())),
        diameter=math.sqrt(d1 * d2),
        aspect=max(d1, d2) / min(d1, d2),
        visible=float(np.count_nonzero(hull_img)) / max(full, 1.0),
        iou=inter / union if union else 0.0,
        arc_residual=arc_residual,
        edge_residual=edge_residual,
    )


def _hole_counts(holes: NDArray[np.bool_], area: float) -> tuple[int, int]:
    """Holes of more than 2 % and of more than 0.4 % of the area."""
    if not holes.any():
        return 0, 0
    # Only the sizes count, so plain labels and their histogram (no OpenCV statistics).
    n, labels = cv2.connectedComponentsWithAlgorithm(
        holes.view(np.uint8), 4, cv2.CV_16U, cv2.CCL_DEFAULT
    )
    sizes = cv2.calcHist([labels], [0], None, [n], [0, n]).ravel()[1:]
    return int(np.count_nonzero(sizes > 0.02 * area)), int(np.count_nonzero(sizes > 0.004 * area))


def measure_region(component: NDArray[np.bool_]) -> RegionShape | None:
    """Measure one region given as a boolean mask cropped to its bounding box.

    Parameters
    ----------
    component : ndarray, shape (h, w), bool
        The region's pixels inside its own bounding box.

    Returns
    -------
    RegionShape or None
        None when the region has no usable outline.
    """
    h, w = component.shape
    pad = max(2, int(0.35 * max(h, w)))
    canvas = np.zeros((h + 2 * pad, w + 2 * pad), dtype=np.uint8)
    canvas[pad : pad + h, pad : pad + w] = component
    contours, _ = cv2.findContours(canvas, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    if not contours:
        return None
    outline = max(contours, key=cv2.contourArea)
    filled = np.zeros_like(canvas)
    cv2.drawContours(filled, [outline], -1, 1, thickness=-1)
    area = float(np.count_nonzero(filled))
    if area < 4:
        return None
    hull_img = np.zeros_like(canvas)
    cv2.fillConvexPoly(hull_img, cv2.convexHull(outline), 1)
    hull_area = float(np.count_nonzero(hull_img))
    # The outline's shape is judged on the convex hull: dirt, snow and JPEG bite into
    # a real disc's colour region, but its hull stays an ellipse; a box's hull does not.
    hull_outline = np.asarray(
        cv2.findContours(hull_img, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)[0][0], dtype=np.int32
    )
    ellipse, residual = _moment_ellipse(hull_img, hull_outline)
    inter = float(np.count_nonzero(hull_img & ellipse))
    union = float(np.count_nonzero(hull_img | ellipse))
    bw, bh = cv2.boundingRect(outline)[2:]
    large, small = _hole_counts((filled & ~canvas).astype(bool), area)
    solidity = area / hull_area if hull_area else 0.0
    # A cut-disc fit only where it can matter: convex enough, and not a whole ellipse.
    worth = solidity > CUT_SOLIDITY[0] and residual > WHOLE_RESIDUAL
    cut = _fit_cut(hull_img, hull_outline, pad) if worth else None
    return RegionShape(
        area=area,
        fill=hull_area / float(bw * bh),
        ellipse_iou=inter / union if union else 0.0,
        solidity=solidity,
        aspect=max(bw, bh) / max(1, min(bw, bh)),
        hole_fraction=1.0 - float(np.count_nonzero(canvas & filled)) / area,
        large_holes=large,
        holes=small,
        ellipse_residual=residual,
        cut=cut,
    )


def cut_members(shape: RegionShape, diameter: float, p: CameraProfile) -> tuple[float, ...]:
    """Memberships of a disc partly hidden behind a straight edge (a pole, a post)."""
    cut = shape.cut
    if cut is None:
        return (0.0,)
    dmin, dmax = p.disc_diameter_range
    # The whole ellipse's diameter, relative like ``diameter`` (the visible part's).
    full = diameter * cut.diameter / max(math.sqrt(4.0 * shape.area / math.pi), 1e-6)
    return (
        ramp(full, 0.7 * dmin, dmin, dmax, 1.3 * dmax),
        # An arc fit is looser than a whole outline's moments: the full aspect range.
        ramp(cut.aspect, 0.0, 0.0, p.max_aspect, 1.15 * p.max_aspect),
        ramp(cut.iou, CUT_IOU[0], CUT_IOU[1]),
        ramp(cut.arc_residual, -1.0, -1.0, CUT_ARC[0], CUT_ARC[1]),
        ramp(cut.edge_residual, -1.0, -1.0, CUT_EDGE[0], CUT_EDGE[1]),
        ramp(cut.visible, CUT_VISIBLE[0], CUT_VISIBLE[1]),
    )
