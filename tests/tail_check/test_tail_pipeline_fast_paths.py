"""The verifier's proposal stage answers as the plain computations its fast paths replace.

``tail_check.confirm`` builds the whole frame's maps and proposals for every ``present``;
the speed work on them must give the very same proposals (positions, radii, sources and
responses, in the same order), bit for bit.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from tail_check.pipeline import PIPELINE_PROFILE
from tail_check.pipeline.proposals import (
    LIT_SOURCE,
    PROPOSAL_PARAMS,
    Maps,
    Proposal,
    ProposalParams,
    _blobs,
    _peaks,
    _regions,
    make_maps,
)
from tail_check.synth import iter_snapshots


def _maps(count: int = 12) -> list[Maps]:
    """Maps of generator A's snapshots (red cars, lamps and lettering among them)."""
    return [make_maps(image, PIPELINE_PROFILE) for image, _ in iter_snapshots(5, count)]


def _plain_regions(m: Maps, c: ProposalParams) -> list[Proposal]:
    """The region proposals as first written, with OpenCV's statistics."""
    rmin, rmax = (f * c.work_side for f in c.radius_range)
    amin, amax = math.pi * rmin**2, math.pi * (2 * rmax) ** 2
    masks = [(m.chroma >= cr) & (m.redness >= rd) for cr, rd in c.levels] + [m.band]
    out: list[Proposal] = []
    for level, mask in enumerate(masks, start=1):
        n, _, stats, cents = cv2.connectedComponentsWithStats(mask.astype(np.uint8), connectivity=8)
        areas = stats[1:n, cv2.CC_STAT_AREA]
        order = [int(i) + 1 for i in np.argsort(-areas) if amin <= areas[i] <= amax]
        for k in order[: c.max_regions]:
            bw, bh = float(stats[k, cv2.CC_STAT_WIDTH]), float(stats[k, cv2.CC_STAT_HEIGHT])
            r = 0.25 * (bw + bh)
            if rmin <= r <= rmax:
                cx, cy = float(cents[k][0]), float(cents[k][1])
                out.append(Proposal(cx, cy, r, level, float(areas[k - 1]) / (bw * bh)))
    return out


def _plain_blobs(m: Maps, c: ProposalParams, lit: bool) -> list[Proposal]:
    """The blob proposals as first written: both box means and the dilation per radius,
    over the whole frame."""
    out: list[Proposal] = []
    source, field = (LIT_SOURCE, m.value) if lit else (0, m.evidence)
    floor = c.min_lit_response if lit else c.min_response
    for frac in c.lit_radii if lit else c.blob_radii:
        r = frac * c.work_side
        k_in = max(1, int(round(2 * c.centre_sigma * r)) | 1)
        k_out = max(3, int(round(2 * c.surround_sigma * r)) | 1)
        diff = cv2.blur(field, (k_in, k_in)) - cv2.blur(field, (k_out, k_out))
        size = max(3, 2 * int(r) + 1)
        peaks = (diff >= cv2.dilate(diff, np.ones((size, size), np.uint8))) & (diff >= floor)
        ys, xs = np.nonzero(peaks)
        strength = diff[ys, xs]
        for i in np.argsort(-strength)[: c.max_blobs]:
            out.append(Proposal(float(xs[i]), float(ys[i]), r, source, float(strength[i])))
    return out


def test_blob_proposals_are_the_whole_frames() -> None:
    found = 0
    for m in _maps():
        for lit in (False, True):
            fast = _blobs(m, PROPOSAL_PARAMS, lit)
            assert fast == _plain_blobs(m, PROPOSAL_PARAMS, lit)
            found += len(fast)
    assert found > 0


def test_peaks_at_the_border_and_without_any() -> None:
    rng = np.random.default_rng(list(b"peaks"))
    for _ in range(200):
        h, w = (int(v) for v in rng.integers(3, 60, 2))
        diff = rng.random((h, w)).astype(np.float32) ** 4
        size, floor = 2 * int(rng.integers(1, 8)) + 1, float(rng.uniform(0.2, 1.1))
        plain = (diff >= cv2.dilate(diff, np.ones((size, size), np.uint8))) & (diff >= floor)
        where = _peaks(diff, size, floor)
        ys, xs = np.nonzero(plain)
        if where is None:
            assert len(xs) == 0
        else:
            assert where.tolist() == np.stack([xs, ys], axis=1).tolist()


def test_region_proposals_are_those_of_opencvs_statistics() -> None:
    found = 0
    for m in _maps():
        fast = _regions(m, PROPOSAL_PARAMS)
        assert fast == _plain_regions(m, PROPOSAL_PARAMS)
        found += len(fast)
    assert found > 0
