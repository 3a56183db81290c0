"""Stages 1+2 together: the candidates of one snapshot, each with its feature vector.

Proposals (:mod:`.proposals`) from blobs and colour regions often describe the same
disc several times; after segmentation (:mod:`.features`) candidates whose circles
nearly coincide are merged, keeping the one with the strongest proposal.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..profile import CameraProfile
from .features import FEATURE_NAMES, FEATURE_PARAMS, BBox, Candidate, FeatureParams, describe
from .proposals import PROPOSAL_PARAMS, Maps, Proposal, ProposalParams, make_maps, propose

__all__ = [
    "FEATURE_NAMES",
    "Candidate",
    "CandidateParams",
    "candidates_of",
    "find_candidates",
    "iter_candidates",
]


@dataclass(frozen=True)
class CandidateParams:
    """Parameters of the candidate stages.

    Attributes
    ----------
    proposals, features : the two stages' own parameters.
    same_centre : two circles are one candidate when their centres are closer than
        this many radii ...
    same_radius : ... and their radii differ by less than this factor.
    max_candidates : candidates verified per snapshot, strongest proposals first.
    """

    proposals: ProposalParams = PROPOSAL_PARAMS
    features: FeatureParams = FEATURE_PARAMS
    same_centre: float = 0.4
    same_radius: float = 1.35
    max_candidates: int = 24


CANDIDATE_PARAMS = CandidateParams()


def _same(a: tuple[float, float, float], b: tuple[float, float, float], c: CandidateParams) -> bool:
    ra, rb = a[2], b[2]
    close = math.hypot(a[0] - b[0], a[1] - b[1]) <= c.same_centre * max(ra, rb)
    return close and max(ra, rb) <= c.same_radius * max(1e-3, min(ra, rb))


def _inside(pr: Proposal, m: Maps, where: BBox) -> bool:
    """Whether a proposal's centre, in image pixels, lies in the box ``where``."""
    x, y = m.origin[0] + pr.cx / m.scale, m.origin[1] + pr.cy / m.scale
    return where[0] <= x <= where[0] + where[2] and where[1] <= y <= where[1] + where[3]


def iter_candidates(
    m: Maps, params: CandidateParams = CANDIDATE_PARAMS, where: BBox | None = None
) -> Iterator[Candidate]:
    """Merged, described candidates of prepared maps, strongest proposal first, described
    only as they are asked for (describing is most of the stage's time, and a caller that
    has its answer can stop); with ``where`` (x, y, w, h in image pixels) only those
    proposed there."""
    props = sorted(propose(m, params.proposals), key=lambda p: -p.response)
    if where is not None:
        props = [pr for pr in props if _inside(pr, m, where)]
    red_share = float((m.redness >= params.features.red_pixel).mean())
    scene = (m.bright, red_share)
    found: list[Candidate] = []
    for pr in props:
        if len(found) >= params.max_candidates:
            return
        cand = describe(m, pr, scene, params.features)
        if cand is None or any(_same(cand.circle, f.circle, params) for f in found):
            continue
        found.append(cand)
        yield cand


def candidates_of(
    m: Maps, params: CandidateParams = CANDIDATE_PARAMS, where: BBox | None = None
) -> list[Candidate]:
    """All of :func:`iter_candidates`."""
    return list(iter_candidates(m, params, where))


def find_candidates(
    image: NDArray[np.uint8],
    p: CameraProfile,
    params: CandidateParams = CANDIDATE_PARAMS,
    *,
    where: BBox | None = None,
) -> tuple[list[Candidate], Maps]:
    """Candidates of one BGR snapshot under a camera profile (only those proposed inside
    ``where``, image pixels, when given), and the maps they came from."""
    m = make_maps(image, p, params.proposals)
    return candidates_of(m, params, where), m
