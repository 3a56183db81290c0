"""A lit lamp is no tail disc: a clipped core whose light fades out in a glow.

The tail disc is a painted disc with a retro-reflector: it is lit by the light around
it and ends in an outline as sharp as the camera's focus. An electric tail lamp, a
signal head or a road vehicle's rear light at dusk or night is a light source: the
sensor clips at its core (near white, or red at full scale) and the light fades out
over a halo. Colour and roundness cannot tell them apart (the halo of a round lamp is
a perfect disc of red), the outline can: this module measures how wide the fall from
inside the region to its surroundings is, along rays from the region's centre, on the
working image before the low-pass (which would widen every edge alike).

A disc whose reflector shines in a headlight also has a clipped core, but its painted
field still ends at a sharp outline, so it stays a disc. A region that only glows is
at most ``uncertain`` (a person must look), never ``present``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ._rays import sample_rays

__all__ = ["LAMP_CHECK", "LampCheck", "glow_width", "lamp_reason"]


@dataclass(frozen=True)
class LampCheck:
    """Parameters of the lit-lamp check (lengths relative to the working image).

    Attributes
    ----------
    core_level : float
        Brightest channel (0..255, working image before the low-pass) at or above
        which the region's centre counts as clipped: a light source, or a reflector
        shining in a headlight. Below it the check does not apply. Every lamp and
        signal measured (generators A and B, tuning seeds 310000+) clips at 255, while
        a red field in sunlight, unclipped, reaches 230-249 (half of generator A's
        regions that bright), and its rim can fall over as much as a glow's: at 230 a
        sunlit disc of generator A's seed 7, the service tests' arrival photo, was held
        ``uncertain``.
    core_share : float
        Inner part of the region (fraction of its radius) searched for the clipped core.
    inner, outer : float
        The fall is measured from ``inner`` to ``outer`` times the region's radius: from
        inside the disc's painted field (past its reflector) to well outside its rim.
    step : float
        Sampling step along each ray, working pixels.
    rays : int
        Directions sampled around the centre (the median over them is used, so a
        bracket, a pole or a rim gap in a few directions does not count).
    max_edge_width : float
        Widest fall from inside to outside that is still an outline, as a fraction of
        the working image's side (``WORK_SIDE``). The fall's width is its depth divided
        by its steepest slope: a blurred step is about 2.5 blur sigmas wide, a glow a
        third of its radius. Measured on generator B's seeds 310000-312000 and
        320000-320900 (never the held-out ones): discs with a clipped reflector
        1.7-3.3 working pixels (of 400), lamps and signals 4.0-7.5.
    """

    core_level: float = 250.0
    core_share: float = 0.5
    inner: float = 0.6
    outer: float = 1.6
    step: float = 0.5
    rays: int = 32
    max_edge_width: float = 0.009


LAMP_CHECK = LampCheck()


def _ray_profiles(
    value: NDArray[np.float32], centre: tuple[float, float], radius: float, c: LampCheck
) -> NDArray[np.float32]:
    """Brightness along ``c.rays`` rays from the centre out to ``c.outer`` radii, one row
    per ray, sampled every ``c.step`` pixels (bilinear)."""
    steps = np.arange(0.0, c.outer * radius + c.step, c.step, dtype=np.float32)
    return sample_rays(value, centre, steps, c.rays)


def glow_width(
    value: NDArray[np.float32],
    centre: tuple[float, float],
    radius: float,
    c: LampCheck = LAMP_CHECK,
) -> float | None:
    """Width (working pixels) of the fall from the region's inside to its surroundings,
    or None when the region has no clipped core (the check does not apply).

    ``value`` is the brightest channel of the working image before the low-pass;
    ``centre`` and ``radius`` are the region's in working pixels.
    """
    profiles = _ray_profiles(value, centre, radius, c)
    core = max(1, int(round(c.core_share * radius / c.step)))
    if float(profiles[:, :core].max()) < c.core_level:
        return None
    start = min(int(round(c.inner * radius / c.step)), profiles.shape[1] - 2)
    tail = profiles[:, start:]
    # Depth: from inside the field down to the darkest point outside (a dark rim
    # counts as outside); slope: the steepest descent on the way.
    depth = tail[:, 0] - tail.min(axis=1)
    slope = np.maximum(-np.diff(tail, axis=1), 0.0).max(axis=1) / c.step
    widths = depth / np.maximum(slope, np.finfo(np.float32).eps)
    return float(np.median(widths))


def lamp_reason(
    value: NDArray[np.float32],
    centre: tuple[float, float],
    radius: float,
    work_side: float,
    c: LampCheck = LAMP_CHECK,
) -> str | None:
    """Why the region is a lit lamp rather than a disc, or None when it is not one."""
    width = glow_width(value, centre, radius, c)
    if width is None or width <= c.max_edge_width * work_side:
        return None
    return (
        f"clipped bright core whose light fades out over {width:.1f} working pixels "
        "(no sharp outline): a lit lamp or signal, not a reflector disc; a person must look"
    )
