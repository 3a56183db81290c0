"""The hand-tuned detector's candidate passes over the working crop.

In order, until one candidate settles the search (reaches the profile's ``present``
threshold and is no lit lamp): the camera's band ``c_ref ± c_Δ``, then the wider and
pale seed bands of :mod:`tail_check.seeds`, then, on a red car body, the search by the
disc's rim (:mod:`tail_check.rims`). Every pass holds a lit lamp (:mod:`tail_check.lamps`)
just below the threshold, so that a lamp never ends the search for the real disc.
"""

from __future__ import annotations

import math
from dataclasses import replace

import cv2
import numpy as np
from numpy.typing import NDArray

from .colour import band_mask
from .lamps import LAMP_CHECK, lamp_reason
from .pixels import channel_extreme
from .profile import CameraProfile
from .regions import DiscCandidate, find_candidates
from .rims import rim_candidates
from .seeds import Band, in_band, seed_passes

__all__ = ["RED_BODY_SHARE", "search_passes"]

RED_BODY_SHARE = 0.12
"""Share of the search region in the disc's colour above which a red car body is assumed
and the disc is also searched by its rim."""


def _without_lamps(
    found: list[DiscCandidate],
    work: NDArray[np.uint8],
    p: CameraProfile,
    *,
    origin: tuple[int, int],
    scale: float,
    work_side: float,
) -> list[DiscCandidate]:
    """Candidates best first, each that would be ``present`` but is a lit lamp (a clipped
    core fading out in a glow, :mod:`tail_check.lamps`) held just below the threshold."""
    if not any(c.score >= p.present_threshold and c.glow is None for c in found):
        return sorted(found, key=lambda c: -c.score)
    value = channel_extreme(work, cv2.max).astype(np.float32)
    below = math.nextafter(p.present_threshold, 0.0)
    out = []
    for c in found:
        if c.score >= p.present_threshold and c.glow is None:
            x, y, w, h = c.bbox
            # Box centre in working pixels (pixel centres at integer coordinates).
            centre = ((x - origin[0] + w / 2) * scale - 0.5, (y - origin[1] + h / 2) * scale - 0.5)
            radius = c.diameter * work_side / 2
            reason = lamp_reason(value, centre, radius, work_side, LAMP_CHECK)
            if reason is not None:
                c = replace(c, score=min(c.score, below), glow=reason)
        out.append(c)
    return sorted(out, key=lambda c: -c.score)


def search_passes(
    smooth: NDArray[np.uint8],
    clear: NDArray[np.uint8],
    band: NDArray[np.bool_],
    valley_free: NDArray[np.bool_],
    p: CameraProfile,
    *,
    work: NDArray[np.uint8],
    origin: tuple[int, int],
    scale: float,
    sigma_px: float,
    work_side: float,
) -> list[DiscCandidate]:
    """All candidate passes, best first: camera band, wider and pale seed bands, rim
    search. A lit lamp never settles the search: the real disc may still be found.

    ``smooth`` and ``clear`` are the working crop (``work``) low-passed and not, both with
    the veil subtracted; ``band`` its pixels in the camera's band, ``valley_free`` those
    not in a dark valley; boxes come out in image pixels (``origin``, ``scale``: the
    crop's origin and the image-to-working scale; ``work_side``: the working side).
    """

    def seeded(
        seed_band: NDArray[np.bool_], found: list[DiscCandidate], colour: Band | None = None
    ) -> list[DiscCandidate]:
        more = find_candidates(
            seed_band & valley_free,
            seed_band,
            smooth,
            valley_free,
            p,
            origin=origin,
            scale=scale,
            work_side=work_side,
        )
        if colour is not None:  # a seed's blurred edge can lead anywhere: keep its colour
            more = [c for c in more if in_band(c.mean_rgb, colour)]
        return _without_lamps(
            found + more, work, p, origin=origin, scale=scale, work_side=work_side
        )

    def settled(found: list[DiscCandidate]) -> bool:
        return bool(found) and found[0].score >= p.present_threshold

    found = seeded(band, [])
    wide = band
    for index, (seed, gate) in enumerate(seed_passes(p)):
        if settled(found):
            break
        seeds = band_mask(smooth, seed[0], seed[1], gain_range=seed[2])
        wide = seeds if index == 0 else wide
        found = seeded(seeds, found, gate)
    red_share = float(np.count_nonzero(band)) / max(1.0, float(band.size))
    if red_share > RED_BODY_SHARE and not settled(found):
        sharp_red = np.asarray(
            cv2.GaussianBlur(clear[..., 2], (0, 0), min(sigma_px, 0.8)), dtype=np.uint8
        )
        # The rim is the evidence here (on a red body any circle is in the band), so the
        # inside only has to be in the wider band: snow and fog veil a disc's colour.
        found += rim_candidates(
            wide, smooth, sharp_red, p, origin=origin, scale=scale, work_side=work_side
        )
        found = _without_lamps(found, work, p, origin=origin, scale=scale, work_side=work_side)
    return found
