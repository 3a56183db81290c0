"""Seed bands of the detector's passes after the camera band.

The camera band ``c_ref ± c_Δ`` (:mod:`tail_check.colour`) finds a disc in its paint as
the camera was calibrated for; fog, rain and faded paint move a real disc off it. Seeds
from wider bands are re-extracted with their own colour at c_Δ and must pass the same
disc checks (:mod:`tail_check.regions`), so a wider band only finds, never accepts.
"""

from __future__ import annotations

import numpy as np

from .colour import band_mask
from .profile import CameraProfile

__all__ = [
    "FADED",
    "PALE_ACCEPT",
    "PALE_MIN_GAIN",
    "PALE_SEED",
    "WIDE_SEED",
    "Band",
    "in_band",
    "seed_passes",
]

WIDE_SEED = 1.4
"""Seed band width for the second pass, in multiples of the profile's c_Δ."""
FADED = 0.25
"""Share of white in a faded disc's paint: the third pass seeds from the camera's
reference colour mixed with this much white (red paint chalks and bleaches towards
pink, green and blue rising together; an orange or brown stays out)."""
PALE_SEED = 1.0
"""Seed band width for the third pass (around the faded colour), in multiples of c_Δ."""
PALE_ACCEPT = 0.6
"""Band width (multiples of c_Δ) around the faded colour that a third-pass region's mean
colour must lie in: narrow enough that a tan or orange (green well above blue) is out."""
PALE_MIN_GAIN = 0.5
"""Lowest exposure gain of the faded seed band: a faded disc is pale, not dark."""

Band = tuple[tuple[float, float, float], float, tuple[float, float]]
"""A colour band: reference RGB, half-width c_Δ, exposure gain range."""


def in_band(rgb: tuple[float, float, float], band: Band) -> bool:
    """Whether one RGB colour lies in the band."""
    pixel = np.array([[[rgb[2], rgb[1], rgb[0]]]], np.float32)
    return bool(band_mask(pixel, band[0], band[1], gain_range=band[2])[0, 0])


def seed_passes(p: CameraProfile) -> tuple[tuple[Band, Band | None], ...]:
    """Seed bands of the passes after the camera band, each with the band a region's mean
    colour must lie in (None: any colour that passes the disc checks).

    Fog, rain and faded paint move a real disc off the camera band; seeds from wider
    bands are re-extracted with their own colour at c_Δ and must pass the same disc
    checks, so a wider band only finds, never accepts. The faded band takes in the pink
    of a sun-bleached disc; a seed's blurred edge can lead to a region of any colour, so
    there the region's own colour must be faded red too. Below a gain of PALE_MIN_GAIN
    the faded band would take in every dark brown shadow.
    """
    low, high = p.gain_range
    r, g, b = ((1.0 - FADED) * c + FADED * 255.0 for c in p.reference_rgb)
    gains = (min(max(low, PALE_MIN_GAIN), high), high)
    return (
        ((p.reference_rgb, WIDE_SEED * p.c_delta, p.gain_range), None),
        (((r, g, b), PALE_SEED * p.c_delta, gains), ((r, g, b), PALE_ACCEPT * p.c_delta, gains)),
    )
