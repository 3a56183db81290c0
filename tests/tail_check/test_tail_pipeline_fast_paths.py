"""The verifier's proposal stage answers as the plain computations its fast paths replace.

``tail_check.confirm`` builds the whole frame's maps and proposals for every ``present``;
the speed work on them must give the very same proposals (positions, radii, sources and
responses, in the same order), bit for bit.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from tail_check.colour import band_mask
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


def _plain_layers(image: np.ndarray, c: ProposalParams) -> list[np.ndarray]:
    """The stack's layers as first written, on the interleaved float image's channels."""
    p = PIPELINE_PROFILE
    scale = c.work_side / math.sqrt(image.shape[0] * image.shape[1])
    size = (max(8, round(image.shape[1] * scale)), max(8, round(image.shape[0] * scale)))
    work = cv2.resize(image, size, interpolation=cv2.INTER_AREA if scale < 1 else cv2.INTER_LINEAR)
    work = cv2.GaussianBlur(work, (0, 0), p.sigma * c.work_side)
    bgr = np.asarray(work, np.float32)
    b, g, r = bgr[..., 0], bgr[..., 1], bgr[..., 2]
    top = work.max(axis=2).astype(np.float32)
    redness = np.clip((r - np.maximum(g, b)) / (r + 1.0), 0.0, 1.0)
    chroma = r / (r + g + b + 3.0)
    bright = max(c.min_bright, float(np.quantile(top, c.bright_quantile)) / 255.0)
    value = np.clip(top / (255.0 * bright), 0.0, 1.0)
    evidence = redness * np.clip(value / c.value_knee, 0.0, 1.0)
    med = np.array([np.median(work[..., k]) for k in range(3)], np.float32) + 1.0
    balanced = bgr * (float(med.mean()) / med).astype(np.float32)[None, None, :]
    wb_top = np.maximum(balanced[..., 1], balanced[..., 0])
    red_wb = np.clip((balanced[..., 2] - wb_top) / (balanced[..., 2] + 1.0), 0.0, 1.0)
    band = band_mask(work, p.reference_rgb, p.c_delta, gain_range=p.gain_range)
    clipped = top >= c.clip_level
    return [bgr, redness, chroma, value, evidence, band, redness**2, red_wb, clipped]


def test_maps_are_the_interleaved_computations() -> None:
    for image, _ in iter_snapshots(6, 8, size=(960, 540)):
        m = make_maps(image, PIPELINE_PROFILE)
        bgr, *layers = _plain_layers(image, PROPOSAL_PARAMS)
        assert np.array_equal(m.bgr, bgr)
        assert m.stack.shape == (*m.redness.shape, 9) and np.all(m.stack[..., 0] == 1.0)
        for k, layer in enumerate(layers, start=1):
            assert np.array_equal(m.stack[..., k], layer.astype(np.float32)), k
        named = (m.redness, m.chroma, m.value, m.evidence, m.band)
        assert all(np.array_equal(a, b) for a, b in zip(named, layers[:5], strict=True))


def test_region_proposals_are_those_of_opencvs_statistics() -> None:
    found = 0
    for m in _maps():
        fast = _regions(m, PROPOSAL_PARAMS)
        assert fast == _plain_regions(m, PROPOSAL_PARAMS)
        found += len(fast)
    assert found > 0
