"""Overlay rendering and the ε(c_Δ) study."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from tail_check import detect, overlay_png, render_overlay
from tail_check.colour import band_mask, filter_kernel, low_pass
from tail_check.study import StudySample, epsilon_curves, extraction_error
from tail_check.synth import iter_snapshots, render_snapshot


def test_overlay_draws_box_region_and_verdict_without_touching_input() -> None:
    image, _ = render_snapshot(30, disc=True, condition="day", distractors=(), occlusion=0.0)
    before = image.copy()
    result = detect(image)
    out = render_overlay(image, result)
    assert np.array_equal(image, before)
    assert out.shape == image.shape and out.dtype == np.uint8
    x, y, w, h = result.bbox  # type: ignore[misc]
    assert tuple(out[y, x + w // 2]) == (60, 200, 60)  # green box edge: present
    assert not np.array_equal(out[:20], image[:20])  # verdict banner
    png = overlay_png(image, result)
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    decoded = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_COLOR)
    assert np.array_equal(decoded, out)
    with pytest.raises(ValueError, match="image"):
        render_overlay(cv2.resize(image, (100, 80)), result)


@pytest.mark.parametrize("kind", ["box", "disk", "gaussian"])
def test_filter_kernels_are_normalised_low_pass(kind: str) -> None:
    k = filter_kernel(kind, 7)  # type: ignore[arg-type]
    assert k.shape == (7, 7) and k.sum() == pytest.approx(1.0, abs=1e-6)
    assert k[3, 3] >= k[0, 0]
    flat = np.full((20, 20, 3), 77.0, np.float32)
    assert np.allclose(low_pass(flat, kind, 7), 77.0, atol=1e-3)  # type: ignore[arg-type]
    with pytest.raises(ValueError):
        filter_kernel("median", 3)  # type: ignore[arg-type]


def test_band_is_per_channel_around_reference() -> None:
    ref = (200.0, 40.0, 40.0)  # mean 93.3, c_Δ 25 % -> ±23.3 on each channel
    # BGR: disc, brighter disc (R 224 > 223.3), red-brown car (G/R 0.45), half-lit disc
    img = np.array([[[40, 40, 200], [40, 40, 224], [40, 90, 200], [20, 20, 100]]], np.uint8)
    assert band_mask(img, ref, 0.25).tolist() == [[True, False, False, False]]
    # an exposure range accepts the same red at other brightness, never the brown
    wide = band_mask(img, ref, 0.25, gain_range=(0.4, 1.2)).tolist()
    assert wide == [[True, True, False, True]]


def test_extraction_error_is_exact_on_a_clean_disc() -> None:
    img = np.full((100, 100, 3), (90, 120, 60), np.float32)
    disc = np.zeros((100, 100), np.uint8)
    cv2.circle(disc, (50, 50), 10, 1, -1)
    img[disc > 0] = (40, 40, 200)
    img[(disc > 0) & (np.arange(100)[None, :] >= 50)] = (40, 40, 180)  # unevenly painted
    s_ref = float(disc.mean())
    ref = (200.0, 40.0, 40.0)
    assert extraction_error(img, s_ref, ref, 0.25) == pytest.approx(0.0)
    # a 1 % band takes only the brighter half: ε = the other half's share
    dim = float(((disc > 0) & (np.arange(100)[None, :] >= 50)).mean())
    assert extraction_error(img, s_ref, ref, 0.01) == pytest.approx(dim)


def test_study_reproduces_the_papers_finding_on_generated_images() -> None:
    samples = [
        StudySample(img, lab.disc_fraction, lab.reference_point, lab.bbox)
        for img, lab in iter_snapshots(41, 60, size=(480, 360))
        if lab.disc and lab.reference_point is not None and lab.bbox is not None
    ]
    result = epsilon_curves(samples)
    assert result.count == len(samples) >= 20
    i25 = result.deltas.index(0.25)
    g, b, d = (result.mean_error[k] for k in ("gaussian", "box", "disk"))
    assert g[i25] <= b[i25] and g[i25] <= d[i25]  # Gaussian lowest ε
    # ε falls from small c_Δ and rises again on reddish cars at large c_Δ
    assert g[i25] < g[0] and g[i25] < g[-1]
    assert 0.1 <= result.deltas[int(np.argmin(g))] <= 0.45
    assert "gaussian" in result.table()
    with pytest.raises(ValueError, match="no labelled image"):
        epsilon_curves([])
