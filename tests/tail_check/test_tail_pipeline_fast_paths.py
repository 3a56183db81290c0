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
    PROPOSAL_PARAMS,
    Maps,
    Proposal,
    ProposalParams,
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


def test_region_proposals_are_those_of_opencvs_statistics() -> None:
    found = 0
    for m in _maps():
        fast = _regions(m, PROPOSAL_PARAMS)
        assert fast == _plain_regions(m, PROPOSAL_PARAMS)
        found += len(fast)
    assert found > 0
